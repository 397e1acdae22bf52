"""The example notebook runs from top to bottom without an error (executed by nbclient, as CI does)."""

import pathlib
import re

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")
pytest.importorskip("ipywidgets")
pytest.importorskip("matplotlib")

NOTEBOOK = pathlib.Path(__file__).resolve().parents[1] / "examples" / "notebook.ipynb"


def test_the_example_notebook_executes():
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(
        notebook,
        kernel_name="python3",
        timeout=300,
        resources={"metadata": {"path": str(NOTEBOOK.parent)}},
    )
    client.execute()  # raises CellExecutionError, naming the cell, on any error
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    # The frame's own picture, the five terms, the comparison, the cel term: all drawn.
    assert len(images) >= 6
    printed = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    found = re.search(r"largest difference from the built-in diffuse: (\S+)", printed)
    assert found and float(found.group(1)) <= 1e-5
