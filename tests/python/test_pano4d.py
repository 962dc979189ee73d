"""The Python module on the tiny synthetic scene: every exposed function,
its arrays against the command line's outputs, an error per stage, Ctrl-C.

Run by ctest (python_module_test) with PYTHONPATH at build/python and
PANO4D_BINARY naming the pano4d binary the module was built with.
"""
import json
import os
import signal
import struct
import subprocess
import threading

import numpy as np
import pytest

import pano4d

BINARY = os.environ.get("PANO4D_BINARY", "")


def cli(*args):
    """The binary, as a shell runs it; returns (status, output)."""
    assert BINARY, "PANO4D_BINARY must name the pano4d binary (ctest sets it)"
    r = subprocess.run([BINARY, *args], capture_output=True, text=True)
    return r.returncode, r.stdout + r.stderr


@pytest.fixture(scope="session")
def tiny(tmp_path_factory):
    """The tiny synthetic dataset, a workspace with its depth and a short
    fit, and the same workspace's depth alone for the interrupt tests."""
    root = tmp_path_factory.mktemp("tiny")
    dataset = root / "tiny"
    assert pano4d.command(["-q", "synth", "--preset", "tiny", "--seed", "3",
                           "--out", str(dataset)]) == 0
    ws = root / "ws"
    frames = pano4d.depth(dataset=dataset, workspace=ws, quiet=True)
    seen = []
    fit = pano4d.fit(workspace=ws, iterations=30, quiet=True,
                     progress=lambda p: seen.append(p))
    return {"root": root, "dataset": dataset, "ws": ws, "frames": frames,
            "fit": fit, "progress": seen}


def test_version_is_the_binarys():
    status, out = cli("--version")
    assert status == 0
    assert out.split() == ["pano4d", pano4d.__version__]


def test_stages_return_their_summaries(tiny):
    assert len(tiny["frames"]["train"]) == 8
    fit = tiny["fit"]
    assert fit["iterations"] == 30
    assert fit["termination"] == "iterations done"
    # progress: one call per iteration, with the run's numbers.
    its = [p["iteration"] for p in tiny["progress"]]
    assert its == list(range(1, 31))
    assert all(p["iterations"] == 30 for p in tiny["progress"])
    assert all(np.isfinite(p["loss"]) and p["gaussians"] > 0
               for p in tiny["progress"])
    assert tiny["progress"][-1]["val_psnr"] is not None


def test_workspace_arrays(tiny):
    ws = pano4d.Workspace(tiny["ws"])
    train = ws.frames("train")
    assert [f["name"] for f in train] == [
        f["name"] for f in tiny["frames"]["train"]]
    f = train[0]
    cam = f["camera"]
    assert cam.K.shape == (3, 3) and cam.world_to_camera.shape == (4, 4)
    image = ws.image(f["name"])
    assert image.shape == (cam.height, cam.width, 3) and image.dtype == np.uint8
    assert np.array_equal(image, pano4d.read_image(f["rgb"]))
    depth = ws.depth(f["name"])
    assert depth.shape == (cam.height, cam.width) and (depth > 0).any()
    assert ws.num_times == tiny["frames"]["num_times"]
    assert ws.summary("fit")["iterations"] == 30
    assert ws.summary("frames")["num_times"] == ws.num_times
    assert set(ws.stamps()) >= {"depth", "fit"}
    assert ws.plan() is None  # no pano4d.run here
    assert len(ws.frames("val")) == 16


def read_ply(path):
    """A binary little-endian 3DGS PLY: {property: column}."""
    with open(path, "rb") as f:
        names, count = [], 0
        while True:
            line = f.readline().decode().strip()
            if line.startswith("element vertex"):
                count = int(line.split()[2])
            elif line.startswith("property"):
                names.append(line.split()[2])
            elif line == "end_header":
                break
        data = np.frombuffer(f.read(4 * len(names) * count), "<f4")
    data = data.reshape(count, len(names))
    return {n: data[:, i] for i, n in enumerate(names)}


def test_scene_at_equals_the_exported_ply(tiny):
    scene = pano4d.Workspace(tiny["ws"]).scene()
    manifest = pano4d.export(workspace=tiny["ws"], quiet=True)
    assert len(manifest["frames"]) == scene.num_times
    for frame in (manifest["frames"][0], manifest["frames"][-1]):
        at = scene.scene_at(frame["time"])
        ply = read_ply(tiny["ws"] / "pano4d/export/ply" / frame["file"])
        n = scene.num_static + scene.num_dynamic
        assert at["means"].shape == (n, 3) and len(ply["x"]) == n
        means = np.stack([ply["x"], ply["y"], ply["z"]], 1)
        assert np.array_equal(at["means"], means)
        assert np.array_equal(
            at["log_scales"], np.stack([ply[f"scale_{i}"] for i in range(3)], 1))
        assert np.array_equal(
            at["quats"], np.stack([ply[f"rot_{i}"] for i in range(4)], 1))
        assert np.array_equal(at["opacity_logits"], ply["opacity"])
        assert np.array_equal(
            at["sh"][:, 0, :], np.stack([ply[f"f_dc_{i}"] for i in range(3)], 1))
        # Views, not copies; the derived values are what they say.
        assert not at["means"].flags.owndata
        assert np.allclose(at["opacities"], 1 / (1 + np.exp(-ply["opacity"])))
        assert np.allclose(np.linalg.norm(at["rotations"], axis=1), 1)
        assert at["dynamic"].sum() == scene.num_dynamic
    bases = scene.motion_bases()
    assert bases["rotations"].shape == (scene.num_bases, scene.num_times, 4)
    assert bases["logits"].shape == (scene.num_dynamic, scene.num_bases)
    with pytest.raises(pano4d.Error, match="must be in"):
        scene.scene_at(scene.num_times)


def test_render_equals_pano4d_render(tiny):
    orbit = tiny["root"] / "orbit"
    status, log = cli("-q", "render", "--workspace", str(tiny["ws"]),
                      "--frames", "2", "--out", str(orbit))
    assert status == 0, log
    # The orbit's cameras as a file, rendered again from it: the cameras
    # Python reads from the same file.
    cameras = orbit / "cameras.json"
    again = tiny["root"] / "again"
    status, log = cli("-q", "render", "--workspace", str(tiny["ws"]),
                      "--trajectory", str(cameras), "--out", str(again))
    assert status == 0, log
    scene = pano4d.Workspace(tiny["ws"]).scene()
    views = pano4d.read_cameras(cameras)
    assert len(views) == 2
    for i, view in enumerate(views):
        cam = view["camera"]
        r = pano4d.render(scene, cam, view["t"])
        png = pano4d.read_image(again / f"{i:05d}.png")
        assert np.array_equal(r["image"], png)
        assert r["depth"].shape == (cam.height, cam.width)
        assert ((r["alpha"] >= 0) & (r["alpha"] <= 1)).all()
    with pytest.raises(pano4d.Error, match="fitted scene's times"):
        pano4d.render(scene, cam, -1)
    half = pano4d.render(scene, cam, 0, width=cam.width // 2,
                         height=cam.height // 2)
    assert half["image"].shape == (cam.height // 2, cam.width // 2, 3)
    # A camera of one's own: a training camera moved sideways.
    own = pano4d.Workspace(tiny["ws"]).frames("train")[0]["camera"]
    own.translation = own.translation + np.array([0.05, 0.0, 0.0])
    moved = pano4d.render(scene, own, 0)
    assert moved["alpha"].mean() > 0.5


def test_evaluate_equals_pano4d_eval(tiny):
    renders = tiny["ws"] / "pano4d/renders/val"
    out = tiny["root"] / "eval_cli"
    status, log = cli("-q", "eval", "--dataset", str(tiny["dataset"]),
                      "--renders", str(renders), "--out", str(out))
    assert status == 0, log
    metrics = pano4d.evaluate(tiny["dataset"], renders,
                              out=tiny["root"] / "eval_py", quiet=True)
    assert metrics == json.loads((out / "metrics.json").read_text())
    assert metrics["mean"]["psnr"] > 10


def test_help_is_the_command_lines():
    text = pano4d.help("fit")
    assert "--iterations" in text and "--resume" in text
    status, out = cli("fit", "--help")
    assert out.strip() == text.strip()


# One bad input per stage: a Python exception carrying pano4d's message.
def test_errors_raise_pano4d_error(tiny, tmp_path):
    missing = tmp_path / "missing"
    with pytest.raises(pano4d.Error, match="missing"):
        pano4d.Workspace(missing)
    with pytest.raises(pano4d.Error, match="--iterations"):
        pano4d.fit(workspace=tiny["ws"], iterations=-5)
    with pytest.raises(pano4d.Error, match="holds a fit already"):
        pano4d.fit(workspace=tiny["ws"], iterations=5, quiet=True)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(pano4d.Error, match="pano4d depth"):
        pano4d.fit(workspace=empty, quiet=True)
    with pytest.raises(pano4d.Error, match="no-such-dataset"):
        pano4d.depth(dataset=tmp_path / "no-such-dataset", workspace=empty)
    with pytest.raises(pano4d.Error):
        pano4d.sfm(workspace=empty, quiet=True)
    with pytest.raises(pano4d.Error):
        pano4d.expand(workspace=empty, quiet=True)
    with pytest.raises(pano4d.Error):
        pano4d.export(workspace=empty, quiet=True)
    with pytest.raises(pano4d.Error):
        pano4d.run(workspace=empty, quiet=True)
    with pytest.raises(pano4d.Error):
        pano4d.evaluate(tiny["dataset"], tmp_path / "no-renders")
    with pytest.raises(pano4d.Error, match="fit"):
        pano4d.Workspace(empty).scene()
    with pytest.raises(pano4d.Error, match="not-a-flag"):
        pano4d.fit(workspace=tiny["ws"], not_a_flag=1)


def fresh_workspace(tiny, name):
    ws = tiny["root"] / name
    pano4d.depth(dataset=tiny["dataset"], workspace=ws, quiet=True)
    return ws


def test_ctrl_c_stops_a_fit_with_its_checkpoint(tiny):
    ws = fresh_workspace(tiny, "ws_interrupt")

    def interrupt(p):
        if p["iteration"] == 10:
            os.kill(os.getpid(), signal.SIGINT)  # what Ctrl-C sends

    with pytest.raises(KeyboardInterrupt):
        pano4d.fit(workspace=ws, iterations=40, quiet=True,
                   checkpoint_every=1000, progress=interrupt)
    assert (ws / "pano4d/checkpoints/fit.ckpt").exists()
    assert not (ws / "pano4d/fit.json").exists()
    resumed = pano4d.fit(workspace=ws, iterations=40, resume=True, quiet=True)
    assert resumed["iterations"] == 40
    assert resumed["resumed_at"] in (10, 11)


def test_progress_returning_false_stops_and_the_gil_is_released(tiny):
    ws = fresh_workspace(tiny, "ws_stop")
    ticks, at = [], {}
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(1)
            done.wait(0.001)

    def progress(p):
        at[p["iteration"]] = len(ticks)
        return p["iteration"] < 20

    thread = threading.Thread(target=count)
    thread.start()
    try:
        s = pano4d.fit(workspace=ws, iterations=40, quiet=True,
                       progress=progress)
    finally:
        done.set()
        thread.join()
    assert s["termination"] == "stopped"
    assert max(at) == 20
    # The other thread ticked between iterations 1 and 20: the fit does not
    # hold the GIL (holding it, the thread would wait for the whole fit).
    assert at[20] - at[1] > 20, at


def test_run_and_expand_return_their_summaries(tiny):
    ws = tiny["root"] / "ws_run"
    plan = pano4d.run(dataset=tiny["dataset"], workspace=ws, eval=True,
                      iterations=40, expand_every=20, validate_every=20,
                      quiet=True)
    assert {s["stage"] for s in plan["stages"] if s["run"]} >= {"fit", "eval"}
    assert plan["results"]["fit"]["status"] == "done"
    assert plan == pano4d.Workspace(ws).plan()
    steps = pano4d.expand(workspace=ws, directions=1, expansion_steps=1,
                          expansion_stride=4, panorama_width=64, quiet=True)
    assert [s["step"] for s in steps] == [1]


def test_priors_written_from_python_are_read_as_written(tiny):
    """A script's own priors (here the scene's own depth, masks and a
    made-up flow and tracks) in the layouts --priors reads, read back as a
    fit reads them, then taken by the depth stage."""
    ws = pano4d.Workspace(tiny["ws"])
    priors = tiny["root"] / "priors"
    train = ws.frames("train")
    rng = np.random.default_rng(0)
    written = {}
    for f in train:
        depth = ws.depth(f["name"])
        disparity = np.where(depth > 0, 1 / np.maximum(depth, 1e-6), 0)
        pano4d.write_disparity(priors, f["name"], disparity)
        written[f["name"]] = disparity.astype(np.float32)
        mask = ws.dynamic_mask(f["name"])
        pano4d.write_mask(priors, f["name"], mask)
    h, w = written[train[0]["name"]].shape
    flow = rng.normal(0, 1, (h, w, 2)).astype(np.float32)
    valid = rng.random((h, w)) > 0.3
    a, b = (os.path.basename(f["rgb"]) for f in train[:2])
    pano4d.write_flow(priors, a, b, flow, valid)
    tracks = rng.uniform(0, [w, h], (len(train), 5, 2)).astype(np.float32)
    visible = rng.random((len(train), 5)) > 0.2
    pano4d.write_tracks(priors, tracks, visible)

    kinds = {l["kind"] for l in pano4d.scan_priors(priors)["layouts"]}
    assert kinds == {"depth", "flow", "tracks", "masks"}
    read = pano4d.read_priors(priors, tiny["ws"])
    assert read["frames"] == [f["name"] for f in train]
    assert read["depth"]["meaning"] == "disparity"
    for name, disparity in written.items():
        assert np.array_equal(read["depth"]["maps"][name], disparity)
        assert np.array_equal(read["masks"]["maps"][name],
                              ws.dynamic_mask(name))
    (field,) = read["flow"]["fields"]
    assert (field["from"], field["to"]) == (train[0]["name"], train[1]["name"])
    assert np.array_equal(field["flow"], flow)
    assert np.array_equal(field["valid"], valid)
    assert field["mask_source"] == "file"
    assert np.array_equal(read["tracks"]["pixels"], tracks)
    assert np.array_equal(read["tracks"]["visible"], visible)

    frames = pano4d.depth(dataset=tiny["dataset"],
                          workspace=tiny["root"] / "ws_priors",
                          priors=priors, quiet=True)
    assert os.path.samefile(frames["priors"], priors)
    with pytest.raises(pano4d.Error, match="NaN"):
        pano4d.write_disparity(priors, "bad", np.full((h, w), np.nan))
    with pytest.raises(pano4d.Error, match="ending in 2"):
        pano4d.write_flow(priors, a, b, np.zeros((h, w, 3)))
