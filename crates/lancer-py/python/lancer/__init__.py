"""Lancer for Python: a Whitted ray tracer whose illumination model is a list of terms.

Scenes are loaded from Lancer's TOML files, edited (materials, lights, camera, image) and
rendered to NumPy arrays: the beauty image and one image per term, which sum to it. Terms can be
written in Python and used in a model like the built-in ones.

    import lancer
    scene = lancer.load("scenes/showcase.toml")
    scene.materials["gold"].shine = 0.9
    frame = scene.render(width=320, terms="ambient,diffuse,specular:blinn")
    frame.layers["specular"].max(), frame.stats["rays"]["total"]

In a notebook a frame shows itself (its beauty image, then a strip of its per-term images).
"""

import base64 as _base64
import html as _html

from ._lancer import (  # noqa: F401  (the public API)
    Camera,
    Chunk,
    Frame,
    Image,
    Light,
    LightSample,
    Material,
    Materials,
    Scene,
    SceneError,
    load,
    loads,
    register_term,
    terms,
    unregister_term,
)

__all__ = [
    "Camera",
    "Chunk",
    "Frame",
    "Image",
    "Light",
    "LightSample",
    "Material",
    "Materials",
    "Scene",
    "SceneError",
    "load",
    "loads",
    "register_term",
    "terms",
    "unregister_term",
]


def _exposure(array):
    """The factor that puts a layer's brightest 99.5th-percentile value at 1 (1 for black)."""
    import numpy as np

    peak = float(np.percentile(array, 99.5)) if array.size else 0.0
    return 1.0 / peak if peak > 0 else 1.0


def _frame_html(self):
    """The beauty image, then each per-term image (each at its own exposure, said below it)."""
    cells = []

    def cell(title, png, note):
        data = _base64.b64encode(png).decode("ascii")
        return (
            '<figure style="display:inline-block;margin:0 6px 6px 0;text-align:center">'
            f'<img src="data:image/png;base64,{data}" style="image-rendering:pixelated;max-width:240px"/>'
            f'<figcaption style="font:12px sans-serif">{_html.escape(title)}'
            f'<br><span style="color:#777">{_html.escape(note)}</span></figcaption></figure>'
        )

    cells.append(cell("beauty", self.png(), "exposure 1"))
    for name, array in self.layers.items():
        if name == "background" and not array.any():
            continue
        k = _exposure(array)
        cells.append(cell(name, self.png(layer=name, exposure=k), f"exposure ×{k:.3g}"))
    return '<div class="lancer-frame">' + "".join(cells) + "</div>"

