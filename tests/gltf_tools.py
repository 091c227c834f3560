"""Running the Khronos glTF validator from tests (npm package ``gltf-validator``).

Set ``QUADSIM_GLTF_VALIDATOR`` to the package folder (``.ci/run`` does); without it
the tests that need the validator skip, unless ``node_modules/gltf-validator``
sits in the repository.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def validator_dir() -> Path:
    """The gltf-validator package folder, or skip (fail when configured but missing)."""
    env = os.environ.get("QUADSIM_GLTF_VALIDATOR")
    node = shutil.which("node")
    if env:
        cands = [Path(env), Path(env) / "node_modules" / "gltf-validator"]
        found = [c for c in cands if (c / "package.json").is_file()]
        if not found:
            pytest.fail(f"QUADSIM_GLTF_VALIDATOR={env!r} holds no gltf-validator package")
        if node is None:
            pytest.fail("QUADSIM_GLTF_VALIDATOR is set but `node` is not on the PATH")
        return found[0]
    local = REPO / "node_modules" / "gltf-validator"
    if node is None or not (local / "package.json").is_file():
        pytest.skip("Khronos glTF validator not installed: `npm install --prefix /tmp/gltfv "
                    "gltf-validator` and set QUADSIM_GLTF_VALIDATOR="
                    "/tmp/gltfv/node_modules/gltf-validator")
    return local


def validate(*files) -> list[dict]:
    """The validator's report of each file, in order."""
    proc = subprocess.run(["node", str(REPO / "tests" / "gltf_validate.mjs"),
                           str(validator_dir()), *map(str, files)],
                          check=False, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)
