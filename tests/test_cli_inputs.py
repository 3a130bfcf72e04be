"""Bad binary inputs through the commands that read them: one line naming the file, exit 2, and no
output folder left behind."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from swarm.cli import main

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture()
def truncated_map(tmp_path) -> Path:
    """maps/test_small.yaml pointing at the first 3000 bytes of its grid (issue 15)."""
    doc = yaml.safe_load((REPO / "maps" / "test_small.yaml").read_text())
    grid = (REPO / "maps" / doc["grid"]).read_bytes()
    (tmp_path / "x.npz").write_bytes(grid[:3000])
    doc["grid"] = "x.npz"
    path = tmp_path / "x.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.mark.parametrize("command", ["map info", "plan", "simulate"])
def test_a_truncated_grid_is_one_line_and_exit_2(truncated_map, tmp_path, command, capsys) -> None:
    out = tmp_path / "out"
    if command == "map info":
        argv = ["map", "info", str(truncated_map)]
    else:
        argv = [command, str(REPO / "missions" / "landing.yaml"), "--set", f"map={truncated_map}"]
        argv += ["--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err == (
        f"swarm: error: {truncated_map.parent / 'x.npz'}: (file): found '3000 bytes that are not a whole "
        "zip archive', expected an .npz grid (numpy.savez) holding arrays 'terrain' and 'elevation_m'\n"
    )
    assert not out.exists()
