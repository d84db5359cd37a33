"""Named parameter presets: one name for one complete set of shared values.

- `literal`: the most literal reading of the paper and the spec (params.py's
  defaults): discovery per agent (P_γ = v·g(d)), d_max the search space's
  bound R, abandonment once per visit, g without v, r_msg fitted to M1's
  2.46 min alone.
- `study-calibrated`: the readings and unstated values fitted jointly for
  M1 and M2 to the study's eight published split cells by
  `hcss simulate calibrate --to study` (fit_study.py), everything else as
  `literal`. docs/simulation-notes.md gives the fit, its command and what it
  reaches out of sample.
- `study-units`: the same calibration to the study's tables in full under
  the study's own unit (38 numbers: means, SDs, medians, units per split),
  with the readings of issue 28 in the search (the easy layout's other sites
  strictly farther, the label "best not the furthest" by 100 m ring, F_D's
  wait scaled). The default (`DEFAULT_PRESET`): out of sample its loss over
  those numbers is below `study-calibrated`'s and `literal`'s on two scenario
  blocks (docs/simulation-notes.md).

A preset's name is stored in every trial's params (`Params.preset`), so a
trial records which preset it ran, and any value changed after choosing one.
"""

from __future__ import annotations

from hcss.simulation.params import Params

LITERAL = "literal"
STUDY_CALIBRATED = "study-calibrated"
STUDY_UNITS = "study-units"

PRESETS: dict[str, Params] = {
    LITERAL: Params(),
    # `hcss simulate calibrate --to study` (120 trials, sampler seed 1, scenarios from
    # 20150000): out/calibration/fit.json, rounded to the digits shown.
    STUDY_CALIBRATED: Params(
        preset=STUDY_CALIBRATED,
        discovery="spatial",
        abandonment="per_visit",
        m2_g_reading="distance_only",
        m2_distance_bounds="fitted",
        message_rate=1.707,
        sensing_radius_m=8.86,
        fitted_d_max_m=352.1,
        abandon_scale=1.325,
        turn_sd_rad=0.982,
    ),
    # `hcss simulate calibrate --to study --scenarios 14 --runs 10 --budget 26`
    # (issue 28: the tables in full under the study's unit; sampler seed 1,
    # scenarios from 20150000): fit.json, rounded to the digits shown.
    STUDY_UNITS: Params(
        preset=STUDY_UNITS,
        discovery="spatial",
        abandonment="per_visit",
        m2_g_reading="distance_only",
        m2_distance_bounds="fitted",
        message_rate=2.047,
        sensing_radius_m=9.58,
        fitted_d_max_m=430.0,
        abandon_scale=2.615,
        turn_sd_rad=0.445,
        easy_layout_others="strictly_farther",
        difficulty_label="best_not_furthest",
        label_distances="ring",
        m2_discovery_wait_scale=0.153,
    ),
}

# The default: the preset of every `hcss simulate` command without --preset, of a
# study file without `[simulation] preset` (its live trials) and of a bot trial
# started without one. Chosen by evidence: the lowest loss over the study's 38
# published numbers under its unit (bands 10 points, 1 min, 30 units) on two
# scenario blocks no calibration saw, seeds from 50000000 and 60000000 (28 x 10):
# study-units 46.1 / 54.1, study-calibrated 83.3 / 74.5, literal 187.7 / 174.8
# (docs/simulation-notes.md). A study file naming a preset keeps it: the bundled
# original and demo studies name study-calibrated.
DEFAULT_PRESET = STUDY_UNITS


def preset_params(name: str = DEFAULT_PRESET) -> Params:
    """The preset's params; a clear error naming the presets for an unknown name."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"no preset {name!r}; presets: {', '.join(PRESETS)}") from None
