"""The Python module against the command line: the same images, errors, edits and registry.

Run after ``pip install .`` with ``pytest python/tests``; ``RAYLAB_BIN`` names the ``raylab``
binary to compare with (default: the repository's target/debug/raylab, then target/release).
"""

import _thread
import os
import re
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import raylab

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell_box.ron"


def raylab_bin() -> Path:
    given = os.environ.get("RAYLAB_BIN")
    if given:
        return Path(given)
    for profile in ("debug", "release"):
        candidate = ROOT / "target" / profile / "raylab"
        if candidate.exists():
            return candidate
    pytest.fail("no raylab binary: build it (cargo build) or set RAYLAB_BIN")


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(raylab_bin()), *args], capture_output=True, text=True, timeout=600
    )


def cli_render(tmp_path: Path, scene: Path, *flags: str) -> np.ndarray:
    out = tmp_path / "cli.exr"
    done = cli("render", str(scene), "--quiet", "-o", str(out), *flags)
    assert done.returncode == 0, done.stderr
    return raylab.read(out)


def test_the_registry_is_the_command_lines():
    listing = cli("integrators").stdout
    names = [e["name"] for e in raylab.integrators()]
    listed = re.findall(r"^(\S+)\n    ", listing, flags=re.M)
    assert names == listed
    path = next(e for e in raylab.integrators() if e["name"] == "path")
    depth = next(p for p in path["params"] if p["name"] == "max-depth")
    assert depth["kind"] == "depth"
    assert depth["default"] == float("inf")
    assert "-p max-depth=<depth>  (default unlimited)" in listing
    whitted = next(e for e in raylab.integrators() if e["name"] == "whitted")
    depth = whitted["params"][0]
    assert f"-p max-depth=<depth>  (default {depth['default']})" in listing


# Integrators of camera paths, of light paths that splat onto the film, of both, and of
# photons with state across passes.
@pytest.mark.parametrize(
    "integrator,params",
    [
        ("path", {}),
        ("lighttracer", {}),
        ("bdpt", {"max-depth": 4}),
        ("sppm", {"photons": 2000}),
    ],
)
def test_a_render_is_bit_identical_to_the_command_lines(tmp_path, integrator, params):
    scene = raylab.load(CORNELL)
    image = scene.render(integrator, spp=3, size=(40, 32), seed=7, params=params)
    assert image.shape == (32, 40, 3) and image.dtype == np.float32
    flags = ["--integrator", integrator, "--spp", "3", "--size", "40x32", "--seed", "7"]
    for name, value in params.items():
        flags += ["-p", f"{name}={value}"]
    expected = cli_render(tmp_path, CORNELL, *flags)
    assert np.array_equal(image, expected)
    assert image.mean() > 0.01
    sobol = scene.render(integrator, spp=3, size=(40, 32), seed=7, params=params, sampler="sobol")
    assert np.array_equal(sobol, cli_render(tmp_path, CORNELL, *flags, "--sampler", "sobol"))
    assert not np.array_equal(sobol, image)
    spectral = scene.render(integrator, spp=3, size=(40, 32), seed=7, params=params, spectral=True)
    assert np.array_equal(spectral, cli_render(tmp_path, CORNELL, *flags, "--spectral"))
    assert not np.array_equal(spectral, image)
    # The thread count does not change the image.
    assert np.array_equal(
        scene.render(integrator, spp=3, size=(40, 32), seed=7, params=params, threads=1),
        image,
    )


def test_the_variance_is_the_exrs_variance_layer(tmp_path):
    scene = raylab.load(CORNELL)
    image, variance = scene.render("path", spp=4, size=(24, 24), variance=True)
    out = tmp_path / "cli.exr"
    assert cli("render", str(CORNELL), "--quiet", "-o", str(out), "--spp", "4",
               "--size", "24x24").returncode == 0
    cli_image, cli_variance = raylab.read(out, variance=True)
    assert np.array_equal(image, cli_image)
    assert np.array_equal(variance, cli_variance)
    assert (variance > 0).any()
    _, none = scene.render("path", spp=1, size=(8, 8), variance=True)
    assert none is None


def test_defines_reach_a_mitsuba_scene(tmp_path):
    xml = ROOT / "scenes" / "mitsuba" / "cornell_box.xml"
    scene = raylab.load(xml, res=24, spp=2, max_depth=3)
    assert scene.size == (24, 24)
    assert scene.defaults["spp"] == 2
    expected = cli_render(tmp_path, xml, "-D", "res=24", "-D", "spp=2", "-D", "max_depth=3")
    assert np.array_equal(scene.render(), expected)


def test_an_edit_renders_as_the_edited_file_loaded_fresh(tmp_path):
    scene = raylab.load(CORNELL)
    before = scene.render("path", spp=2, size=(32, 32))
    scene.set_material("red", albedo=(0.1, 0.2, 0.9))
    scene.move("small box", translate=(0.1, 0.0, 0.05))
    light = next(e for e in scene.entities if "light" in e)
    scene.set_emitter(light, radiance=(30.0, 25.0, 20.0))
    edited = scene.render("path", spp=2, size=(32, 32))
    assert not np.array_equal(before, edited)
    copy = tmp_path / "edited.ron"
    copy.write_text(scene.to_ron())
    fresh = raylab.load(copy).render("path", spp=2, size=(32, 32))
    assert np.array_equal(edited, fresh)
    # An edit that cannot be made leaves the scene as it was: refused before the world sees
    # it (an unknown field, name), or by the world (an albedo above 1).
    text = scene.to_ron()
    with pytest.raises(ValueError, match="material `red`"):
        scene.set_material("red", no_such_field=1)
    with pytest.raises(KeyError, match="no material `nope`"):
        scene.set_material("nope", albedo=(1, 1, 1))
    with pytest.raises(raylab.RaylabError, match="red"):
        scene.set_material("red", albedo=(2.0, 0.0, 0.0))
    assert scene.to_ron() == text
    assert np.array_equal(scene.render("path", spp=2, size=(32, 32)), edited)


def test_an_imported_scene_moves_by_its_matrix_and_keeps_its_warnings(tmp_path):
    scene = raylab.load(ROOT / "scenes" / "mitsuba" / "cornell_box.xml", res=16, spp=1)
    entity = scene.entities[0]
    with pytest.raises(ValueError, match="placed by a matrix"):
        scene.move(entity, translate=(0, 0.1, 0))
    with pytest.raises(ValueError, match="alone"):
        scene.move(entity, matrix=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0], scale=(2, 2, 2))
    before = scene.render()
    scene.move(entity, matrix=[1, 0, 0, 0.3, 0, 1, 0, 0, 0, 0, 1, 0])
    assert not np.array_equal(scene.render(), before)
    # The load's warnings outlive an edit.
    pbrt = tmp_path / "cloudy.pbrt"
    pbrt.write_text(
        'Camera "perspective"\nFilm "rgb" "integer xresolution" 8 "integer yresolution" 8\n'
        'MakeNamedMedium "c" "string type" "cloud"\nWorldBegin\n'
        'LightSource "infinite" "rgb L" [1 1 1]\nMaterial "diffuse"\nShape "sphere"\n'
    )
    with pytest.raises(raylab.RaylabError, match="--approximate"):
        raylab.load(pbrt)
    cloudy = raylab.load(pbrt, approximate=True)
    assert any("cloud" in w for w in cloudy.warnings)
    cloudy.set_material(cloudy.materials[0])
    assert any("cloud" in w for w in cloudy.warnings)


def test_a_bad_scene_raises_with_its_file_and_line(tmp_path):
    bad = tmp_path / "bad.ron"
    bad.write_text("(\n  camera: LookAt(eye: (0, 0, 1), look_at: (0, 0, 0), fov: 40),\n  entities: [oops],\n)\n")
    with pytest.raises(raylab.RaylabError) as caught:
        raylab.load(bad)
    done = cli("render", str(bad), "--quiet", "-o", str(tmp_path / "x.png"))
    assert done.returncode == 2
    message = str(caught.value)
    assert re.search(r"bad\.ron:3:\d+", message), message
    assert message in done.stderr
    with pytest.raises(raylab.RaylabError, match="no integrator|unknown integrator|not an integrator"):
        raylab.load(CORNELL).render("no-such-integrator", spp=1)


def test_a_callback_sees_each_pass_and_can_stop_the_render():
    scene = raylab.load(CORNELL)
    seen = []
    scene.render("path", spp=4, size=(16, 16), callback=lambda info: seen.append(info["spp"]))
    assert seen == [1, 2, 3, 4]

    def fail(info):
        if info["spp"] == 2:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        scene.render("path", spp=100, size=(16, 16), callback=fail)


def test_ctrl_c_stops_a_render_and_leaves_the_module_usable():
    scene = raylab.load(CORNELL)
    timer = threading.Timer(0.5, _thread.interrupt_main)
    timer.start()
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        scene.render("path", spp=100000, size=(64, 64))
    assert time.monotonic() - start < 30
    timer.join()
    assert scene.render("path", spp=1, size=(8, 8)).shape == (8, 8, 3)


def test_another_thread_runs_while_a_scene_renders():
    scene = raylab.load(CORNELL)
    ticks = []
    done = threading.Event()

    def tick():
        while not done.is_set():
            ticks.append(time.monotonic())
            time.sleep(0.01)

    worker = threading.Thread(target=tick)
    worker.start()
    start = time.monotonic()
    scene.render("path", time=1.0, size=(64, 64))
    end = time.monotonic()
    done.set()
    worker.join()
    during = [t for t in ticks if start < t < end]
    assert len(during) > 20, f"{len(during)} ticks in {end - start:.2f} s"


def test_images_round_trip_through_exr_and_png(tmp_path):
    image = np.random.default_rng(1).random((5, 7, 3), dtype=np.float32) * 4
    raylab.write(tmp_path / "a.exr", image)
    assert np.array_equal(raylab.read(tmp_path / "a.exr"), image)
    raylab.write(tmp_path / "a.png", image.astype(np.float64), exposure=-2.0)
    png = raylab.read(tmp_path / "a.png")
    assert png.shape == (5, 7, 3)
    with pytest.raises(ValueError, match="shape"):
        raylab.write(tmp_path / "b.exr", np.zeros((4, 4)))
    with pytest.raises(raylab.RaylabError, match="extension|\\.png or \\.exr"):
        raylab.write(tmp_path / "b.txt", image)


# The figures that do not depend on the machine's speed.
DETERMINISTIC = ["spp", "mse", "mse_ci95", "relmse", "variance", "bias2", "flip", "hdrflip",
                 "rmse", "psnr", "mean", "ztest_failed_pixels", "rays_camera",
                 "rays_extension", "rays_shadow"]


def test_compare_gives_the_command_lines_figures_and_images(tmp_path, monkeypatch):
    import json

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    flags = ["-i", "path", "-i", "bdpt", "-p", "bdpt.max-depth=4", "--spp", "4", "--runs", "3",
             "--reference-spp", "32", "--size", "24x20", "--seed", "5"]
    done = cli("compare", str(CORNELL), *flags, "-o", str(tmp_path / "cli"), "--quiet")
    assert done.returncode == 0, done.stderr
    expected = json.loads((tmp_path / "cli" / "metrics.json").read_text())
    result = raylab.compare(
        CORNELL,
        {"path": {}, "bdpt": {"max-depth": 4}},
        spp=4,
        runs=3,
        reference={"spp": 32},
        size=(24, 20),
        seed=5,
        out=tmp_path / "py",
    )
    assert result.labels == ["path", "bdpt"]
    for row, want in zip(result.rows, expected["rows"]):
        for key in DETERMINISTIC:
            assert row[key] == want[key], key
        assert row["mse_ci95"] is not None and row["mse"] > 0
    assert np.array_equal(result.images["bdpt"], raylab.read(tmp_path / "cli" / "bdpt.exr"))
    assert result.reference.shape == (20, 24, 3)
    frame = result.to_pandas()
    assert list(frame.index) == ["path", "bdpt"]
    assert frame.loc["path", "mse"] == result.rows[0]["mse"]
    curves = result.convergence()
    assert set(curves["label"]) == {"path", "bdpt"} and (curves["mse"] > 0).all()


def test_compare_measures_an_edited_scene_as_it_stands(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    scene = raylab.load(CORNELL)
    options = dict(spp=2, reference={"spp": 8}, size=(16, 16), out=tmp_path / "a")
    before = raylab.compare(scene, ["path"], **options)
    scene.set_material("white", albedo=(0.2, 0.2, 0.2))
    options["out"] = tmp_path / "b"
    after = raylab.compare(scene, ["path"], **options)
    # The reference was rendered anew for the edited scene (a cached one of the file would
    # leave the darker renders far from it).
    assert after.reference.mean() < 0.8 * before.reference.mean()
    assert after.rows[0]["mean"][0] < before.rows[0]["mean"][0]
    with pytest.raises(raylab.RaylabError, match="no-such"):
        raylab.compare(scene, ["no-such"], spp=1, out=tmp_path / "c")


def test_compare_takes_samplers_and_light_selections_and_gives_the_spectrum(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    result = raylab.compare(
        CORNELL,
        {"direct": {"light-selection": "bvh"}, "direct@zsobol": {}},
        spp=4,
        runs=2,
        reference={"spp": 16},
        size=(24, 20),
        out=tmp_path / "cmp",
    )
    assert result.labels == ["direct", "direct@zsobol"]
    assert [r["sampler"] for r in result.rows] == ["independent", "zsobol"]
    assert "light-selection=bvh" in result.rows[0]["params"]
    assert all(r["time_to_unit_variance"] > 0 for r in result.rows)
    spectrum = result.error_spectrum()
    assert set(spectrum["label"]) == {"direct", "direct@zsobol"}
    assert (spectrum["power"].dropna() >= 0).all() and spectrum["power"].notna().sum() > 32
    frame = result.to_pandas()
    assert (frame["relmse_robust"] <= frame["relmse"] + 1e-12).all()
    # A choice parameter lists what it takes.
    path = next(e for e in raylab.integrators() if e["name"] == "path")
    choice = next(p for p in path["params"] if p["name"] == "light-selection")
    assert choice["kind"] == "choice" and choice["default"] == "scene"
    assert choice["choices"] == ["scene", "uniform", "power", "bvh"]
    image = raylab.load(CORNELL).render(spp=2, size=(8, 8), sampler="halton")
    assert image.shape == (8, 8, 3) and np.isfinite(image).all()


def test_the_readmes_example_runs(tmp_path, monkeypatch):
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## From Python", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, flags=re.S).group(1)
    (tmp_path / "scenes").symlink_to(ROOT / "scenes")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    exec(compile(code, "README.md", "exec"), {})
    assert raylab.read(tmp_path / "cornell.exr").shape == (256, 256, 3)
