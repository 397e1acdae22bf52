"""A parameter sweep on a dask.distributed cluster: one material's shine × n, rendered as NumPy arrays.

    python sweep_dask.py                                   # 400 renders (20 shine × 20 n) on this machine
    python sweep_dask.py --scheduler tcp://10.0.0.5:8786   # the same code on a running cluster
    python sweep_dask.py --shines 4 --ns 3 --width 96 --out sweep.npz

Without `--scheduler` a `LocalCluster` (one worker process per core, one thread each) is started and
stopped here. On a real cluster, start a scheduler (`dask scheduler`) and workers (`dask worker
tcp://SCHEDULER:8786`, or dask-jobqueue / dask-kubernetes / Coiled), with `pip install ./crates/lancer-py`
done on every worker machine; then pass the scheduler's address. The scene's text is sent with each task,
so workers need no copy of the scene file, but the OBJ and PNG files it names must exist at the same path
on the workers (or be under a shared folder given as the scene's base directory). Terms written in
Python are registered in one process only: register them inside the task function to use them on workers.

Each task renders one row of the sweep (one shine, every n) reusing one loaded scene, so only shading
is redone between renders, never the geometry's BVH. Renders are deterministic: a worker's image has the
same bits as the same render made locally.
"""

import argparse
import contextlib
import pathlib

import numpy as np

import lancer


def render_row(text, base_dir, material, shine, ns, width, layer, threads):
    """Render `material` at one shine and each index of refraction in `ns`: an array (len(ns), H, W, 3)."""
    scene = lancer.loads(text, base_dir=base_dir)
    scene.materials[material].shine = shine
    images = []
    for n in ns:
        scene.materials[material].n = n
        frame = scene.render(width=width, threads=threads)
        images.append(frame.beauty if layer == "beauty" else frame.layers[layer])
    return np.stack(images)


def sweep(client, scene_path, material, shines, ns, width=160, layer="beauty", threads=1):
    """Render every (shine, n) pair on the cluster behind `client`: an array (len(shines), len(ns), H, W, 3)."""
    scene_path = pathlib.Path(scene_path).resolve()
    text = scene_path.read_text()
    lancer.loads(text, base_dir=scene_path.parent).materials[material]  # fail here, not on a worker
    futures = [
        client.submit(render_row, text, str(scene_path.parent), material, float(s), [float(n) for n in ns],
                      width, layer, threads, pure=False)
        for s in shines
    ]
    return np.stack(client.gather(futures))


def default_scene():
    """The clone's showcase scene: the first parent folder of this file holding `scenes/showcase.toml`."""
    here = pathlib.Path(__file__).resolve()
    for folder in here.parents:
        if (folder / "scenes" / "showcase.toml").is_file():
            return folder / "scenes" / "showcase.toml"
    raise SystemExit("give the scene to sweep with --scene (no clone of Lancer around this file)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scheduler", help="address of a running dask scheduler (default: a LocalCluster)")
    parser.add_argument("--scene", type=pathlib.Path, help="scene file (default: the clone's showcase)")
    parser.add_argument("--material", default="glass", help="material to sweep (default: glass)")
    parser.add_argument("--shines", type=int, default=20, help="shine values from 0.5 to 0.99 (default: 20)")
    parser.add_argument("--ns", type=int, default=20, help="indices of refraction from 1.0 to 2.0 (default: 20)")
    parser.add_argument("--width", type=int, default=160, help="image width in pixels (default: 160)")
    parser.add_argument("--layer", default="beauty", help="beauty, or one term's image (default: beauty)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("sweep.npz"), help="output .npz")
    args = parser.parse_args()

    from dask.distributed import Client, LocalCluster

    shines = np.linspace(0.5, 0.99, args.shines)
    ns = np.linspace(1.0, 2.0, args.ns)
    with contextlib.ExitStack() as stack:
        address = args.scheduler or stack.enter_context(LocalCluster(threads_per_worker=1))
        client = stack.enter_context(Client(address))
        print(f"{args.shines * args.ns} renders on {client}")
        images = sweep(client, args.scene or default_scene(), args.material, shines, ns, args.width, args.layer)
    np.savez_compressed(args.out, images=images, shine=shines, n=ns)
    print(f"wrote {args.out}: images {images.shape} {images.dtype}, mean radiance {images.mean():.4f}")


if __name__ == "__main__":
    main()
