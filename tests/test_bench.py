"""The benchmark suite runs and writes its result (``quadsim bench``)."""

import json

from quadsim.cli import main


def test_bench_quick_writes_json(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--max-n", "1", "--characters", "leopard",
                 "--out", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["machine"]["cores"] >= 1 and r["machine"]["numpy"]
    assert r["step"]["leopard"]["pose"]["steps_per_s"] > 0
    assert r["step"]["leopard"]["plan_only"]["steps_per_s"] > 0
    assert r["simulate"]["leopard"]["seconds"] > 0
    assert set(r["many"]["by_n"]) == {"1"} and r["many"]["method"]
    assert r["export"]["bvh"]["bytes"] > 0 and r["export"]["glb"]["bytes"] > 0
    assert r["warm_up"]["compile_s"] > 0 and r["warm_up"]["cached_s"] > 0
    assert "frames per second" in capsys.readouterr().out


def test_bench_rejects_a_bad_size(capsys):
    assert main(["bench", "--max-n", "0"]) == 2
    assert "--max-n" in capsys.readouterr().err
