"""Participant bots: the study walked as a participant would, in process or over HTTP.

`participant` walks one bot through the app with Flask's test client and a
manual clock; `http_load` walks many at once against a running server (the
load tool); `synthetic` drives one live trial with a synthetic operator
(hcss.simulation.synthetic) through the page's protocol; `command` is
`hcss bots`. Nothing else in the platform imports them: they drive it from
outside, through its pages and its API.
"""
