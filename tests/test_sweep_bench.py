"""``python -m benchmarks.sweep`` runs and reports the figures the issue asks for."""

import json
import math
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_the_sweep_benchmark_reports_throughputs_stages_and_the_ratio(tmp_path):
    sys.path.insert(0, str(REPO))  # the checkout's benchmarks/
    from benchmarks.sweep import main

    out = tmp_path / "sweep.json"
    assert main(["--quick", "--out", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["clips"] == 12 and r["in_memory"]["frames_per_s"] > 0
    assert set(r["stages"]["ms_per_clip"]) == {"generate", "measure", "encode", "publish"}
    assert math.isclose(sum(r["stages"]["share"].values()), 1.0)
    assert {"1", "2"} <= set(r["end_to_end"])
    for v in r["end_to_end"].values():
        assert v["frames_per_s"] > 0 and v["clips_per_s"] > 0
    assert r["files_only"]["frames_per_s"] > 0 and r["startup_s"] > 0
    assert len(r["free_cores_before_after"]) == 2
    assert all(0 < c <= 2.2 for c in r["free_cores_before_after"])
    assert math.isclose(r["ratio_2_workers"],
                        r["end_to_end"]["2"]["frames_per_s"] / r["in_memory"]["frames_per_s"])
