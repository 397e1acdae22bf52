"""The dask.distributed sweep example on a LocalCluster: every image equals the same render made here."""

import importlib.util
import pathlib

import numpy as np
import pytest

import lancer
from conftest import SCENES

distributed = pytest.importorskip("dask.distributed")

EXAMPLE = pathlib.Path(__file__).resolve().parents[1] / "examples" / "sweep_dask.py"


def example():
    spec = importlib.util.spec_from_file_location("sweep_dask", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_sweep_on_a_local_cluster_returns_the_local_renders():
    sweep_dask = example()
    shines, ns = [0.6, 0.8, 0.95], [1.0, 1.8]
    scene_path = SCENES / "showcase.toml"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        images = sweep_dask.sweep(client, scene_path, "glass", shines, ns, width=48)
        workers = {w for w in client.run(lambda: 1)}
    assert len(workers) == 2
    assert images.shape == (3, 2, 27, 48, 3) and images.dtype == np.float32
    scene = lancer.load(scene_path)
    for i, shine in enumerate(shines):
        for j, n in enumerate(ns):
            scene.materials["glass"].shine, scene.materials["glass"].n = shine, n
            assert np.array_equal(images[i, j], scene.render(width=48, threads=1).beauty), (shine, n)
    # The sweep sees its parameters: the glass ball's index bends what is seen through it.
    assert not np.array_equal(images[0, 0], images[0, 1])


def test_a_sweep_of_an_unknown_material_fails_before_any_task():
    sweep_dask = example()

    class NoCluster:
        def submit(self, *args, **kwargs):
            raise AssertionError("no task must be sent")

    with pytest.raises(KeyError, match="nosuch"):
        sweep_dask.sweep(NoCluster(), SCENES / "showcase.toml", "nosuch", [0.5], [1.5])
