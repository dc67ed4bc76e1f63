"""The example notebook `examples/tour.ipynb`, executed in a real Jupyter kernel, and its cells'
outputs checked: the first cell's `r` is `stickslip run --json`'s, the Fig. 11 sweep finds the
boundary, the campaign made with a withheld viscous term is diagnosed as `viscous`, and every
plot cell shows a figure. Nothing is written beside the notebook (it runs in memory)."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import nbclient
import nbformat
import pytest

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "examples" / "tour.ipynb"
CLI = ROOT / "target" / "release" / "stickslip"


def text_of(cell: nbformat.NotebookNode) -> str:
    parts = []
    for o in cell.get("outputs", []):
        if o.output_type == "stream":
            parts.append(o.text)
        elif "data" in o and "text/plain" in o.data:
            parts.append(o.data["text/plain"])
    return "\n".join(parts)


def has_image(cell: nbformat.NotebookNode) -> bool:
    return any("data" in o and "image/png" in o.data for o in cell.get("outputs", []))


@pytest.fixture(scope="module")
def executed(tmp_path_factory: pytest.TempPathFactory) -> list[nbformat.NotebookNode]:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    # The kernel's working folder is a fresh temporary one: the tour writes nothing of its own.
    work = tmp_path_factory.mktemp("tour")
    nbclient.NotebookClient(nb, timeout=1200, kernel_name="python3", resources={"metadata": {"path": str(work)}}).execute()
    assert list(work.iterdir()) == [], "the notebook wrote files into its folder"
    return [c for c in nb.cells if c.cell_type == "code"]


def test_first_cell_gives_the_cli_r(executed: list[nbformat.NotebookNode], tmp_path: Path) -> None:
    m = re.search(r"^r = ([0-9.eE+-]+)$", text_of(executed[0]), re.M)
    assert m, text_of(executed[0])
    j = json.loads(subprocess.run(
        [str(CLI), "run", "--k-d", "10000", "--v-d", "1e-3", "--f", "1500", "--v-a", "0.4e-3", "--json",
         "--no-trace", "-o", str(tmp_path / "r.h5")], capture_output=True, text=True, check=True).stdout)
    assert float(m.group(1)) == j["r"]
    assert 0.05 < j["r"] < 1.0


def test_the_plots_are_drawn(executed: list[nbformat.NotebookNode]) -> None:
    assert has_image(executed[1])  # the trace
    assert has_image(executed[3])  # the map with its boundary
    assert has_image(executed[6])  # the diagnosis's traces figure


def test_the_boundary_is_found_near_the_rule_of_thumb(executed: list[nbformat.NotebookNode]) -> None:
    out = text_of(executed[2])
    m = re.search(r"boundary found at (\d+) of (\d+) frequencies", out)
    assert m, out
    assert int(m.group(1)) >= 6 and int(m.group(2)) == 8
    assert "96 points" in out


def test_the_withheld_effect_is_named(executed: list[nbformat.NotebookNode]) -> None:
    assert "Campaign(12 recordings" in text_of(executed[4])
    out = text_of(executed[5])
    assert "verdict: effect ['viscous']" in out, out[-2000:]


def test_the_plan_cell_plans_inside_the_campaigns_springs(executed: list[nbformat.NotebookNode]) -> None:
    out = text_of(executed[7])
    m = re.search(r"(\d+) recordings planned among (\d+) rivals", out)
    assert m, out[-2000:]
    assert int(m.group(1)) == 3 and int(m.group(2)) >= 2
    # The campaign's springs are 10 000 and 15 000 N/m: a plan changes springs, never tunes them.
    m = re.search(r"springs: \[([^\]]*)\]", out)
    assert m, out[-2000:]
    springs = {float(x) for x in m.group(1).split(",")}
    assert springs and springs <= {10_000.0, 15_000.0}, springs
