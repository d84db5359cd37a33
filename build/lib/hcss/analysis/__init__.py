"""Tidy exports in, the study's tables and figures out.

``load`` reads study exports and simulation decision tables, ``measures``
turns them into one value per unit (participant or scenario), ``stats`` and
``posthoc`` test them, ``builders``/``tables``/``figures`` present them and
``report`` runs the whole chain for ``hcss analyze``. Nothing here imports
Flask: the analyst needs only the exported files.
"""
