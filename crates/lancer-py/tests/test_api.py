"""The Python API against the command line: same bits, same statistics, same explanations, the
located errors, edits, the GIL released and Ctrl-C."""

import _thread
import json
import signal
import threading
import time

import numpy as np
import pytest

import lancer
from conftest import SCENES, run_cli

SHOWCASE = SCENES / "showcase.toml"


def test_layers_sum_to_beauty_and_arrays_own_the_render_buffer():
    frame = lancer.load(SHOWCASE).render(width=96)
    assert frame.beauty.shape == (54, 96, 3) and frame.beauty.dtype == np.float32
    assert list(frame.layers) == ["ambient", "diffuse", "specular", "mirror", "refraction", "background"]
    total = np.zeros_like(frame.beauty)
    for layer in frame.layers.values():
        total += layer
    # Summed in layer order, as the renderer sums them: the same bits.
    assert np.array_equal(total, frame.beauty)
    # A view of the buffer the render wrote, not a copy: its base is no NumPy array of its own.
    assert not frame.beauty.flags["OWNDATA"]
    assert frame.beauty.base.base is not None and not isinstance(frame.beauty.base.base, np.ndarray)


def test_renders_are_the_command_lines_bits(tmp_path):
    run_cli("render", SHOWCASE, "--width", 120, "--terms", "ambient,diffuse,specular:blinn,mirror",
            "--max-depth", 3, "-o", tmp_path / "cli.exr", "--aov", tmp_path / "cli", "--quiet")
    frame = lancer.load(SHOWCASE).render(width=120, terms="ambient,diffuse,specular:blinn,mirror", max_depth=3)
    frame.save(tmp_path / "py.exr")
    frame.save_aov(tmp_path / "py")
    assert (tmp_path / "py.exr").read_bytes() == (tmp_path / "cli.exr").read_bytes()
    cli_files = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert cli_files == sorted(p.name for p in (tmp_path / "py").iterdir())
    for name in cli_files:
        if name.endswith((".exr", ".png")):
            assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    manifest = json.loads((tmp_path / "py" / "manifest.json").read_text())
    assert sorted(manifest["files"]) == sorted(f for f in cli_files if f != "manifest.json")


def test_stats_and_explain_are_the_command_lines(tmp_path):
    run_cli("render", SHOWCASE, "--width", 64, "-o", tmp_path / "a.png", "--stats-json", tmp_path / "s.json", "--quiet")
    cli_stats = json.loads((tmp_path / "s.json").read_text())
    scene = lancer.load(SHOWCASE)
    stats = scene.render(width=64).stats
    assert stats.keys() == cli_stats.keys()
    assert stats["rays"] == cli_stats["rays"] and stats["model"] == cli_stats["model"]
    out = run_cli("explain", SHOWCASE, "--width", 64, "--pixel", "30,20", "--json")
    assert scene.explain(30, 20, width=64) == json.loads(out.stdout)
    with pytest.raises(ValueError, match="outside the 64x36 image"):
        scene.explain(64, 0, width=64)


def test_a_material_edit_changes_its_terms_images_only():
    scene = lancer.load(SHOWCASE)
    before = scene.render(width=80, terms="ambient,diffuse,specular")
    red = scene.materials["red"]
    assert red.shine != 0.3
    red.shine = 0.3
    after = scene.render(width=80, terms="ambient,diffuse,specular")
    assert np.array_equal(before.layers["ambient"], after.layers["ambient"])
    assert np.array_equal(before.layers["diffuse"], after.layers["diffuse"])
    assert not np.array_equal(before.layers["specular"], after.layers["specular"])
    # The edit is what a scene file saying so gives, to the bit.
    text = SHOWCASE.read_text()
    head, red_table = text.split("[materials.red]", 1)
    assert "shine = 0.95" in red_table.split("[materials.chrome]")[0]
    edited = lancer.loads(head + "[materials.red]" + red_table.replace("shine = 0.95", "shine = 0.3", 1), base_dir=SCENES)
    again = edited.render(width=80, terms="ambient,diffuse,specular")
    assert np.array_equal(again.beauty, after.beauty)


def test_moving_the_camera_and_back_gives_the_same_bits():
    scene = lancer.load(SHOWCASE)
    first = scene.render(width=64).beauty.copy()
    at = scene.camera.position
    scene.camera.position = (at[0] + 1.0, at[1], at[2])
    moved = scene.render(width=64).beauty
    assert not np.array_equal(first, moved)
    scene.camera.position = at
    assert np.array_equal(scene.render(width=64).beauty, first)


def test_lights_and_image_are_editable():
    scene = lancer.load(SHOWCASE)
    base = scene.render(width=64, terms="diffuse")
    scene.lights[0].intensity = 0.0
    scene.lights[1].intensity = 0.0
    assert not scene.render(width=64, terms="diffuse").layers["diffuse"].any()
    assert base.layers["diffuse"].any()
    scene.image.width, scene.image.height = 40, 30
    assert scene.render().beauty.shape == (30, 40, 3)
    with pytest.raises(ValueError, match=r"expected a number in \[0, 1\]"):
        scene.materials["red"].diff = 2
    with pytest.raises(KeyError, match="the scene's materials are floor, red"):
        scene.materials["gren"]


def test_scene_errors_are_located():
    text = '[camera]\nfrom = [0, 1, -5]\nto = [0, 1, 0]\n\n[[objects]]\nshape = "sphear"\n'
    with pytest.raises(lancer.SceneError) as e:
        lancer.loads(text, name="broken.toml")
    err = e.value
    assert (err.file, err.line, err.column) == ("broken.toml", 6, 9)
    assert "unknown shape `sphear`" in err.message and "sphere" in err.message
    with pytest.raises(lancer.SceneError) as e:
        lancer.load(SCENES / "no-such-scene.toml")
    assert "no-such-scene.toml" in str(e.value) and e.value.line == 0


def test_bad_settings_raise():
    scene = lancer.load(SHOWCASE)
    with pytest.raises(ValueError, match="unknown term `difuse`.*diffuse"):
        scene.render(width=32, terms="ambient,difuse")
    with pytest.raises(ValueError, match="width 0"):
        scene.render(width=0)
    with pytest.raises(ValueError, match="max_depth 65"):
        scene.render(width=32, max_depth=65)
    with pytest.raises(ValueError, match="8192x8192"):
        scene.render(width=16384, height=16384)


def test_saving_into_a_missing_folder_fails_and_writes_nothing(tmp_path):
    frame = lancer.load(SHOWCASE).render(width=32)
    with pytest.raises(ValueError, match="there is no folder"):
        frame.save(tmp_path / "nope" / "a.png")
    with pytest.raises(ValueError, match=r"must end in .png"):
        frame.save(tmp_path / "a.jpg")
    assert list(tmp_path.iterdir()) == []


def test_terms_lists_the_registry():
    entries = {(t["name"], t["variant"]) for t in lancer.terms()}
    assert {("diffuse", "lambert"), ("specular", "phong"), ("specular", "blinn"), ("mirror", "schlick")} <= entries


def test_other_threads_run_while_rendering():
    scene = lancer.load(SHOWCASE)
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    started = time.perf_counter()
    scene.render(width=640, samples=4)
    seconds = time.perf_counter() - started
    stop.set()
    t.join()
    # Held for the whole render, the GIL would have let the thread tick a few times at most.
    assert len(ticks) > 20 * seconds, (len(ticks), seconds)


def test_ctrl_c_interrupts_a_render():
    scene = lancer.load(SHOWCASE)
    # Python's own Ctrl-C handler, whatever the process inherited: started in the background by
    # a non-interactive shell, it ignores SIGINT, and interrupt_main would then do nothing.
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        timer = threading.Timer(0.3, _thread.interrupt_main)
        started = time.perf_counter()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            # Minutes of work on two cores.
            scene.render(width=3840, samples=64)
        assert time.perf_counter() - started < 5.0
    finally:
        signal.signal(signal.SIGINT, inherited)
    # The scene renders again afterwards.
    assert scene.render(width=32).beauty.any()


def test_frames_display_themselves():
    frame = lancer.load(SHOWCASE).render(width=48)
    assert frame._repr_png_().startswith(b"\x89PNG")
    html = frame._repr_html_()
    for name in ["beauty", "ambient", "diffuse", "specular", "mirror", "refraction"]:
        assert f">{name}<" in html
    assert html.count("<img") == 6 + (1 if frame.layers["background"].any() else 0)


def test_scene_errors_pickle_with_their_place():
    import pickle

    with pytest.raises(lancer.SceneError) as caught:
        lancer.loads("[image]\nwidth = -3\n")
    again = pickle.loads(pickle.dumps(caught.value))
    assert type(again) is lancer.SceneError and str(again) == str(caught.value)


def test_an_empty_term_list_is_refused_as_the_command_line_refuses_it():
    scene = lancer.load(SCENES / "showcase.toml")
    for empty in ["", " , ", []]:
        with pytest.raises(ValueError):
            scene.render(width=16, terms=empty)


def test_reading_the_scene_while_it_renders_raises_instead_of_panicking():
    scene = lancer.load(SCENES / "showcase.toml")
    seen = []

    def peek(chunk):
        try:
            scene.materials["red"].shine = 0.5
        except RuntimeError as e:
            seen.append(str(e))
        return np.zeros((len(chunk), 3), dtype=np.float32)

    lancer.register_term(name="py_peek", fn=peek, reads_lights=False)
    scene.render(width=32, terms="ambient,py_peek", threads=1)
    assert seen and all("rendering" in m for m in seen)
    assert scene.materials["red"].shine == pytest.approx(0.95)


def test_adaptive_anti_aliasing_is_the_command_lines_and_samples_turn_it_off(tmp_path):
    text = SHOWCASE.read_text().replace("[image]\n", "[image]\nsamples = { adaptive = 0.3, depth = 3 }\n", 1)
    (tmp_path / "aa.toml").write_text(text)
    run_cli("render", tmp_path / "aa.toml", "--width", 96, "-o", tmp_path / "cli.exr", "--quiet")
    scene = lancer.load(tmp_path / "aa.toml")
    assert scene.image.adaptive == (pytest.approx(0.3), 3)
    assert "adaptive samples (threshold 0.3, depth 3)" in repr(scene.image)
    scene.render(width=96).save(tmp_path / "py.exr")
    assert (tmp_path / "py.exr").read_bytes() == (tmp_path / "cli.exr").read_bytes()
    scene.image.samples = 2
    assert scene.image.adaptive is None and scene.image.samples == 2
