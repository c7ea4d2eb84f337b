"""Claims checked world by world (rwhonet.report.worlds), on a real evaluation's eval.json."""

import copy
import json
import math
from pathlib import Path

import pytest
import yaml
from scipy.stats import t as student_t

from rwhonet.evaluation.intervals import band_chance
from rwhonet.report import worlds as wr

FIXTURE = Path(__file__).parents[1] / "evaluation" / "fixtures" / "ci_pipeline_before" / "eval.json"
PARAMS = {
    "sim": {"profile": "ci"},
    "adapt": {"m_grid": [10, 20], "fallback": {"recipe": "radius+G", "m": 20}},
}


def _cell(pct: float, c1: float = 0.68, c2: float = 0.95) -> dict:
    """A position cell as eval.json writes it (only what the claims read matters)."""
    return {
        "pos_mean": 10 * pct,
        "pos_mean_ci95": 0.1,
        "pos_pct": pct,
        "pos_pct_ci95": 0.01,
        "cover_1sigma": c1,
        "cover_2sigma": c2,
        "n_windows": 100,
    }


def with_position(ev: dict) -> dict:
    """The fixture's evaluation (made before the navigation filter) with its 2D keys."""
    outages = ("30s", "180s")
    ev["position_controls"] = {
        "rows": {
            "fused": {L: _cell(1.2) for L in outages},
            "fused, GNSS distance": {L: _cell(1.15) for L in outages},
            "gyro": {L: _cell(1.4) for L in outages},
            "wheels": {L: _cell(3.4) for L in outages},
        }
    }
    ev["position"] = {m: {L: _cell(1.2) for L in outages} for m in ("WPM", "G", "S", "R")}
    crse = {"crse_cover_1sigma": 0.68, "crse_cover_2sigma": 0.95, "n_windows": 100}
    ev["uncertainty"] = {"models": {"R": {"a_m2": 0.002, **{L: dict(crse) for L in outages}}}}
    return ev


@pytest.fixture
def world() -> wr.World:
    ev = with_position(json.loads(FIXTURE.read_text()))
    return wr.World("ci", ev, copy.deepcopy(PARAMS), "build/ci")


def test_every_claim_is_evaluated_on_a_real_evaluation(world):
    for text, row in wr.verdicts([world]):
        (v,) = row
        assert v.holds is not None, text
        assert v.evidence


def test_recalibration_helps_reads_the_paired_difference(world):
    d = world.ev["differences"]["R - G"]["180s"]
    d["crse_mean"], d["crse_ci95"] = -1.0, 0.5
    assert wr.recalibration_helps(world).holds
    d["crse_ci95"] = 1.5  # the interval reaches 0: not shown
    assert not wr.recalibration_helps(world).holds


def test_r_near_best_uses_five_percent_of_the_better_of_g_and_s(world):
    o = world.ev["overall"]
    o["G"]["180s"]["crse_mean"], o["S"]["180s"]["crse_mean"] = 10.0, 20.0
    o["R"]["180s"]["crse_mean"] = 10.5
    assert wr.r_near_best(world).holds
    o["R"]["180s"]["crse_mean"] = 10.51
    assert not wr.r_near_best(world).holds


def test_default_no_harm_checks_every_m_of_the_grid(world):
    o = world.ev["overall"]
    g = o["G"]["180s"]["crse_mean"]
    o["R[radius+G]@10"]["180s"]["crse_mean"] = g - 1
    o["R[radius+G]@20"]["180s"]["crse_mean"] = g - 1
    assert wr.default_no_harm(world).holds
    o["R[radius+G]@10"]["180s"]["crse_mean"] = g + 0.01
    verdict = wr.default_no_harm(world)
    assert not verdict.holds and "worst m = 10 s" in verdict.evidence


def test_a_world_without_a_model_says_n_a(world):
    del world.ev["overall"]["R[continuous]"]
    assert wr.continuous_near_s(world).holds is None


def test_network_beyond_radius_holds_when_the_interval_holds_zero(world):
    key = next(k for k in world.ev["differences"] if k.startswith("R - WPM-m@"))
    d = world.ev["differences"][key]["180s"]
    d["crse_mean"], d["crse_ci95"] = -0.3, 0.4
    assert wr.network_beyond_radius(world).holds
    d["crse_mean"] = -0.5
    assert not wr.network_beyond_radius(world).holds


def test_ten_seconds_harm_lists_the_recipes_worse_than_g(world):
    for model, by_outage in world.ev["no_harm"].items():
        by_outage["180s"]["worse_on_average"] = model == "R[paper]@10"
    v = wr.ten_seconds_harm(world)
    assert v.holds and v.evidence.endswith("paper")
    world.ev["no_harm"]["R[paper]@10"]["180s"]["worse_on_average"] = False
    assert not wr.ten_seconds_harm(world).holds


def test_render_and_replace_the_section(world, tmp_path):
    other = wr.World("paper_consumer", world.ev, world.params, "build/pc")
    section = wr.render([world, other])
    assert section.startswith(wr.BEGIN) and section.rstrip().endswith(wr.END)
    assert "| claim | `ci` | `paper_consumer` |" in section
    assert section.count("\n| ") == 1 + len(wr.CLAIMS)
    doc = "# Results\n\nintro\n\n" + wr.BEGIN + "\nSTALE-SECTION\n" + wr.END + "\n\n## After\n"
    new = wr.replace_section(doc, section)
    assert "STALE-SECTION" not in new
    assert new.startswith("# Results\n\nintro") and new.endswith("## After\n")
    assert wr.replace_section("# R\n", section).endswith(section)


def test_main_reads_world_folders_and_refuses_a_missing_one(tmp_path, capsys):
    folder = tmp_path / "paper_consumer"
    (folder / "metrics").mkdir(parents=True)
    (folder / "metrics" / "eval.json").write_text(FIXTURE.read_text())
    params = copy.deepcopy(PARAMS)
    params["sim"]["profile"] = "paper_consumer"
    (folder / "params.yaml").write_text(yaml.safe_dump(params))
    results = tmp_path / "results.md"
    results.write_text("# Results\n")
    assert wr.main([str(folder), "--results", str(results)]) == 0
    assert "`paper_consumer`" in results.read_text()
    with pytest.raises(SystemExit) as err:
        wr.main([str(tmp_path / "nowhere")])
    assert err.value.code == 2 and "make worlds" in capsys.readouterr().err


def test_the_2d_claims_read_the_filter_s_controls(world):
    rows = world.ev["position_controls"]["rows"]
    assert wr.fused_within_2pct(world).holds and wr.fused_beats_each_sensor(world).holds
    assert wr.fused_coverage(world).holds and wr.distance_model_same_position(world).holds
    rows["fused"]["180s"]["pos_pct"] = 2.01
    assert not wr.fused_within_2pct(world).holds
    beaten = wr.fused_beats_each_sensor(world)
    assert not beaten.holds  # the gyro alone is better now
    gyro = rows["gyro"]["180s"]
    shown = f"{gyro['pos_pct']:.3f} ± {gyro['pos_pct_ci95']:.3f}"
    assert f"fused 2.010 ± 0.010 %, gyro alone {shown} %" in beaten.evidence
    assert "every cell within what chance gives" in wr.fused_coverage(world).evidence
    rows["fused"]["30s"]["cover_2sigma"] = 0.90  # 2σ below 95 - 3 % on one length
    verdict = wr.fused_coverage(world)
    assert not verdict.holds and "30s 68 / 90 %" in verdict.evidence
    # 90 of 100 inside 2σ: two-sided binomial p 0.02 against 95.45 %
    assert "beyond chance (binomial, 5 %): 30s 2σ (90 % of 100)" in verdict.evidence
    rows["fused"]["30s"]["n_windows"] = 37  # 33 of 37 (p 0.08): what chance gives a calibrated 2σ
    assert "every cell within what chance gives" in wr.fused_coverage(world).evidence
    assert "by test drive" not in wr.fused_coverage(world).evidence  # none in eval.json
    world.ev["position_controls"]["by_drive"] = {
        "V-A": {"180s": _cell(1.1, 0.92, 1.0) | {"n_windows": 39}},
        "V-B": {"30s": _cell(1.3)},  # no window of the longest outage
    }
    verdict = wr.fused_coverage(world)
    assert verdict.evidence.endswith("; by test drive at 180s: V-A 92 / 100 % (39)")
    world.ev["position"]["R"]["180s"]["pos_pct"] = 1.3  # 0.15 % of the distance off
    verdict = wr.distance_model_same_position(world)
    assert not verdict.holds and "(farthest: R)" in verdict.evidence
    del world.ev["position_controls"]
    assert wr.fused_within_2pct(world).holds is None


def test_the_crse_coverage_reads_r_s_calibration(world):
    cells = world.ev["uncertainty"]["models"]["R"]
    assert wr.crse_coverage(world).holds
    cells["180s"]["crse_cover_1sigma"] = 0.50  # 50 of 100 within 1σ: too narrow, beyond chance
    verdict = wr.crse_coverage(world)
    assert not verdict.holds and "180s 50 / 95 %" in verdict.evidence
    assert "180s 1σ (50 % of 100)" in verdict.evidence
    assert "cluster-robust" not in verdict.evidence  # no CRSE cells by test drive
    # four drives alike: 50 % of each drive's 25 windows, t = -3.9 on 3 dof (p 0.03)
    world.ev["uncertainty"]["by_drive"] = {
        f"V-{k}": {"180s": {"crse_cover_1sigma": 0.5, "crse_cover_2sigma": 0.95, "n_windows": 25}}
        for k in "ABCD"
    }
    verdict = wr.crse_coverage(world)
    assert verdict.evidence.endswith("(4 drives, cluster-robust t, 5 %): 180s 1σ (50 % of 100)")
    del world.ev["uncertainty"]
    assert wr.crse_coverage(world).holds is None


def test_the_drive_clustered_p_value_by_hand():
    # Two drives of 10 windows, 90 % and 50 % inside: pooled 70 %, cluster-robust variance
    # 2 / 1 · (2² + 2²) / 20² = 0.04 (above the binomial 0.68 · 0.32 / 20), t = 0.02 / 0.2
    # on 1 dof (a Cauchy): p = 2 (1/2 − atan(0.1) / π)
    p = wr.clustered_share_pvalue([0.9, 0.5], [10, 10], 0.68)
    assert p == pytest.approx(2 * (0.5 - math.atan(0.1) / math.pi), rel=1e-9)
    # drives that agree have no spread between them: the binomial variance under the
    # nominal share holds instead, and the reference keeps its D − 1 = 3 dof
    se = math.sqrt(0.6827 * 0.3173 / 100)
    p = wr.clustered_share_pvalue([0.9] * 4, [25] * 4, 0.6827)
    assert p == pytest.approx(2 * student_t.sf((0.9 - 0.6827) / se, 3), rel=1e-9)
    assert 0.01 < p < 0.05
    # a drive without windows does not count; one drive cannot tell a shift from chance
    assert math.isnan(wr.clustered_share_pvalue([0.9, 0.2], [30, 0], 0.6827))
    assert wr.clustered_share_pvalue([0.68, 0.68, 0.7], [10, 0, 10], 0.68) > 0.5


def test_a_miss_the_binomial_calls_beyond_chance_is_put_to_the_drives_too(world):
    rows = world.ev["position_controls"]["rows"]
    rows["fused"]["30s"]["cover_1sigma"] = 0.90  # 90 of 100 in 1σ: binomial p ~1e-7
    drives = {f"V-{k}": {"30s": _cell(1.2, 0.90, 0.95) | {"n_windows": 25}} for k in "ABCD"}
    world.ev["position_controls"]["by_drive"] = drives
    verdict = wr.fused_coverage(world)
    assert "beyond chance (binomial, 5 %): 30s 1σ (90 % of 100)" in verdict.evidence
    # four drives alike: t = 4.67 on 3 dof, p 0.02: beyond the drives' spread too
    assert "(4 drives, cluster-robust t, 5 %): 30s 1σ (90 % of 100)" in verdict.evidence
    for k, share in zip("ABCD", (1.0, 1.0, 0.96, 0.64), strict=True):
        drives[f"V-{k}"]["30s"]["cover_1sigma"] = share  # the same 90 %, from one drive's miss
    verdict = wr.fused_coverage(world)
    assert "beyond chance (binomial, 5 %): 30s 1σ (90 % of 100)" in verdict.evidence
    assert verdict.evidence.endswith("(4 drives, cluster-robust t, 5 %): none")
    del world.ev["position_controls"]["by_drive"]
    assert "cluster-robust" not in wr.fused_coverage(world).evidence


def test_band_tally_counts_cells_and_what_chance_gives(world):
    cells = {
        "30s": {"cover_1sigma": 0.80, "cover_2sigma": 0.95, "n_windows": 37},  # 1σ above
        "180s": {"cover_1sigma": 0.60, "cover_2sigma": 0.99, "n_windows": 37},  # below, above
        "60s": {"cover_1sigma": 0.70, "cover_2sigma": 0.95, "n_windows": 0},  # no window
    }
    t = wr.band_tally(cells, "cover_1sigma", "cover_2sigma")
    assert (t.cells, t.inside, t.above, t.below) == (4, 1, 2, 1)
    one, two = band_chance(37, 0.6827, 0.05), band_chance(37, 0.9545, 0.03)
    assert t.chance_inside == pytest.approx(2 * (one[0] + two[0]))
    assert t.chance_above == pytest.approx(2 * (one[1] + two[1]))
    assert (t + t).cells == 8 and (t + t).chance_below == pytest.approx(2 * t.chance_below)
    assert "1 of 4 cells inside the band, 2 above (regions too wide), 1 below" in t.said()
    # the worlds' summary adds every world's cells: the fixture's 2 lengths × 2 regions × 2
    line = wr.coverage_summary([world, world])
    assert line.startswith("Coverage over the 2 worlds' cells. 2D, fused: 8 of 8 cells inside")
    assert "R-WhONet's CRSE: 8 of 8 cells inside" in line
    assert line in wr.render([world, world])
