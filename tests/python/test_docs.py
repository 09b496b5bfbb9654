# The examples of docs/PYTHON.md run as written (in a scratch folder, since one writes a file), so
# that the documentation stays true.
import os
import pathlib
import re

import numpy as np
import pytest

DOC = pathlib.Path(__file__).resolve().parents[2] / "docs" / "PYTHON.md"
EXAMPLES = re.findall(r"```python\n(.*?)```", DOC.read_text(), re.S)


def test_the_doc_has_its_seven_examples():
    assert len(EXAMPLES) == 7


@pytest.mark.parametrize("index", range(len(EXAMPLES)))
def test_example_runs(index, tmp_path, capsys):
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        namespace = {}
        exec(compile(EXAMPLES[index], f"PYTHON.md example {index + 1}", "exec"), namespace)
    finally:
        os.chdir(cwd)
    if "signed_distance" in EXAMPLES[index]:
        assert namespace["sdf"].shape == (48, 48, 48)
        out = capsys.readouterr().out
        assert float(out.split("smooth torus ")[1]) < 0.005  # the tessellation's error only
        return
    if "occupancy" in EXAMPLES[index]:
        out = capsys.readouterr().out
        volume = float(out.split("volume ")[1].split()[0])
        assert abs(volume - 1.125) < 0.03  # 200000 samples: a standard error of 0.008
        return
    if "list_intersections" in EXAMPLES[index]:  # the lidar with multiple returns
        assert "twice (glass, then what is behind it)" in capsys.readouterr().out
        returns = namespace["returns"]
        assert returns.shape == (16, 1800, 2)
        assert 0 < namespace["double"].mean() < 0.5
        # Where the beam returns twice, the glass (at x = 3) is the first return.
        first = returns[..., 0][namespace["double"]]
        cos = np.abs(namespace["directions"][..., 0][namespace["double"]])
        np.testing.assert_allclose(first * cos, 3.0, rtol=1e-5)
    elif index == 0:
        assert "returns, nearest" in capsys.readouterr().out
        assert namespace["depth"].shape == (500, 2000)
        assert namespace["points"].shape == (500, 2000, 3)
    elif index == 1:
        assert namespace["visible"].shape == (100, 50)
        assert 0 < namespace["visible"].mean() < 1  # the blocks hide some pairs, not all
        assert "of the pairs see each other" in capsys.readouterr().out
    elif index == 3:
        out = capsys.readouterr().out
        assert "as render(denoise=True): True" in out
        before, after = (float(v) for v in out.split("RMSE ")[1].split(" -> "))
        assert after < 0.7 * before
    else:
        assert (tmp_path / "views.npz").exists()
        assert namespace["images"].shape == (8, 128, 128, 3)
