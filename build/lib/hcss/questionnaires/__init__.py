"""Instrument definitions and pure scoring for the study (numpy/scipy only).

Each instrument is data a form layer can render plus pure functions:

- `consent`: versioned texts under `texts/consent-<version>.md`, agree/decline;
- `demographics`: age band, gender, education, colour vision, experience;
- `mrt`: the Mental Rotations Test with generated Shepard-Metzler figures;
- `pages`: the interface introduction and the debrief, Markdown under `texts/`;
- `post_trial`, `tlx` (NASA-TLX), `sart` (3-D SART): per-model questionnaires;
- `ranking`: the post-experiment ranking of the three models by order met;
- `probes`: SA probe templates and a trial's probe schedule.

`definitions` holds the shared item types, `validate` and `ScoreRow` (a row
of the export's `scores` table). Instrument names and item keys are those of
docs/data-dictionary.md.
"""
