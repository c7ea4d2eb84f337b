"""The report's lines on what the navigation filter took for its figures, and where from."""

import re

from rwhonet.report import tables
from rwhonet.report.tables import _gyro_line, _receiver_line

RECEIVER = {
    "sigma_m": 1.18,
    "tau_s": 100.0,
    "configured_sigma_m": 1.5,
    "fitted": True,
    "n_windows": 1707,
    "nll": {"1.181": 4.1464, "1.67": 4.1507},
}
GYRO = {
    "instability_deg_s": 0.004213,
    "configured_instability_deg_s": 0.01,
    "fitted": True,
    "n_windows": 1707,
    "nll": {"0.0025": 4.1522, "0.005": 4.1464},
}


def test_the_receiver_and_gyro_lines_say_what_was_fitted_and_on_what():
    line = _receiver_line(RECEIVER) + _gyro_line(GYRO)
    assert "σ = 1.18 m (configured 1.5 m; τ = 100 s held; 1707 windows" in line
    assert "1.181 m: 4.146, 1.67 m: 4.151" in line
    assert "B = 0.0042 °/s (configured 0.01 °/s; its correlation time held; 1707 windows" in line
    assert "0.0025 °/s: 4.152, 0.005 °/s: 4.146" in line


def test_figures_not_fitted_are_said_to_be_the_configured_ones():
    held = {**GYRO, "instability_deg_s": 0.01, "fitted": False, "nll": {}}
    assert _gyro_line(held) == " The gyro's bias instability: B = 0.01 °/s as configured."
    assert "σ = 1.5 m as configured (τ = 100 s held)" in _receiver_line(
        {**RECEIVER, "sigma_m": 1.5, "fitted": False}
    )
    assert _gyro_line({}) == "" and _receiver_line({}) == ""  # an eval.json from before


def test_the_chance_line_gives_the_binomial_band_probabilities():
    line = tables.chance_line({180: 37, 30: 236})
    # binomial(236, 0.6827) inside 63.27-73.27 %: 0.892; binomial(37, ·): 0.520 (24-27 windows)
    assert "on these 236 / 37 windows of 30 / 180 s" in line
    assert "1σ share lands inside 68 ± 5 % with probability 89 / 52 %" in line
    # 2σ: 0.971 and 0.585 (35 or 36 of 37 windows)
    assert "2σ share inside 95 ± 3 % with 97 / 59 %" in line
    assert tables.chance_line({}) == ""


def test_a_drive_id_with_a_bar_stays_in_its_table_cell():
    route = "b0c9d2329ad1606b|2018-08-02--08-34-47"  # a comma2k19 route folder's name
    row = f"| {tables.md_cell(route)} | 1.0 |"
    # a Markdown table splits a row at the bars a backslash does not escape
    cells = [c.strip() for c in re.split(r"(?<!\\)\|", row)[1:-1]]
    assert cells == ["b0c9d2329ad1606b\\|2018-08-02--08-34-47", "1.0"]
    assert tables.md_cell("V-Delta2") == "V-Delta2"
