"""Terms written in Python: Lambert re-implemented matches the built-in diffuse image, and a
term's mistakes (an exception, a wrong shape, a NaN) raise instead of rendering."""

import numpy as np
import pytest

import lancer
from conftest import SCENES

SHOWCASE = SCENES / "showcase.toml"


def lambert(chunk):
    """diff · Σ max(N·w, 0) · Col_Ω · Col_L·T, over the lights that reach the hit."""
    total = np.zeros((len(chunk), 3), dtype=np.float32)
    for light in chunk.lights:
        lit = (light.n_dot_w > 0) & light.incoming.any(axis=1)
        total += np.where(lit, light.n_dot_w, 0)[:, None] * light.incoming
    return chunk.diff[:, None] * chunk.color * total


def test_lambert_in_python_matches_the_built_in_diffuse():
    lancer.register_term("py_lambert", lambert)
    scene = lancer.load(SHOWCASE)
    ours = scene.render(width=160, terms="ambient,py_lambert")
    theirs = scene.render(width=160, terms="ambient,diffuse")
    assert ours.layers["py_lambert"].any()
    assert np.abs(ours.layers["py_lambert"] - theirs.layers["diffuse"]).max() <= 1e-5
    assert np.array_equal(ours.layers["ambient"], theirs.layers["ambient"])
    listed = [t for t in lancer.terms() if t["name"] == "py_lambert"]
    assert listed and listed[0]["python"] and listed[0]["variant"] == "python"


def test_a_python_term_has_parameters_and_is_used_in_a_scene_model():
    seen = {}

    def flat(chunk):
        seen.update(chunk.params)
        assert chunk.lights == []
        return np.tile(np.float32(chunk.params["level"]) * chunk.color, 1)

    lancer.register_term("py_flat", flat, reads_lights=False, params={"level": 0.5})
    text = (SCENES / "showcase.toml").read_text()
    model = 'terms = ["ambient", "diffuse", "specular", "mirror", "refraction"]'
    assert model in text
    scene = lancer.loads(text.replace(model, 'terms = ["py_flat:level=0.25"]'), base_dir=SCENES)
    assert "py_flat" in scene.model
    frame = scene.render(width=64)
    assert seen == {"level": 0.25}
    # On a camera ray's hit: level times Col_Ω exactly (weights are one there).
    layer = frame.layers["py_flat"]
    assert layer.max() <= 0.25 * 1.0 + 1e-7 and layer.any()
    with pytest.raises(ValueError, match="unknown parameter|`levle`"):
        scene.render(width=16, terms="py_flat:levle=1")


def test_registering_again_replaces_the_function():
    lancer.register_term("py_const", lambda c: np.full((len(c), 3), 0.1))
    scene = lancer.load(SHOWCASE)
    a = scene.render(width=32, terms="py_const").layers["py_const"].max()
    lancer.register_term("py_const", lambda c: np.full((len(c), 3), 0.2))
    b = scene.render(width=32, terms="py_const").layers["py_const"].max()
    assert (a, b) == (np.float32(0.1), np.float32(0.2))
    lancer.unregister_term("py_const")
    with pytest.raises(ValueError, match="unknown term `py_const`"):
        scene.render(width=32, terms="py_const")


def test_a_failing_term_raises_its_error():
    def broken(chunk):
        raise ZeroDivisionError("student's bug")

    lancer.register_term("py_broken", broken)
    scene = lancer.load(SHOWCASE)
    with pytest.raises(ZeroDivisionError, match="student's bug"):
        scene.render(width=64, terms="ambient,py_broken")
    lancer.register_term("py_broken", lambda c: np.zeros((len(c), 2)))
    with pytest.raises(ValueError, match=r"shape \(\d+, 2\); expected \(\d+, 3\)"):
        scene.render(width=64, terms="py_broken")
    lancer.register_term("py_broken", lambda c: np.full((len(c), 3), np.nan))
    with pytest.raises(ValueError, match="must be finite"):
        scene.render(width=64, terms="py_broken")
    with pytest.raises(ValueError, match="built-in term"):
        lancer.register_term("diffuse", lambert)
    with pytest.raises(TypeError, match="callable"):
        lancer.register_term("py_x", 3)
