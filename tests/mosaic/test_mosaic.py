"""The photomosaic (paper 002 §6, docs/MOSAIC.md): the camera that sees the wall, pairwise
registration, global alignment, damaged images, and ``mcl mosaic``. Small images, few of them."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")
pytest.importorskip("scipy")

from app import mosaic as cli
from mosaic import accuracy, alignment, build, illumination, registration
from mosaic.projection import Intrinsics as K
from mosaic.projection import apply, homography, pose_from_world
from vehicle.sensors.camera import Intrinsics, WallCamera, wall_hits
from vehicle.sensors.image_recorder import ImageRecorder
from vehicle.sensors.wall_texture import TextureSpec, WallTexture

SPEC = TextureSpec(seed=7, y_range=(-1.0, 4.0), z_range=(0.0, 3.5))
KK = K(**Intrinsics().__dict__)


@pytest.fixture(scope="module")
def texture() -> WallTexture:
    return WallTexture(SPEC)


def _grey(img: np.ndarray) -> np.ndarray:
    return np.asarray(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY), dtype=np.float32)


def test_camera_renders_the_wall_where_the_pose_says(texture: WallTexture) -> None:
    cam = WallCamera(texture)
    pose = (-1.5, 1.2, 1.6, math.radians(3.0))
    img = cam.render(pose, np.random.default_rng(1))
    assert img.shape == (240, 320, 3)
    y, z, r = wall_hits(pose, cam.a, cam.b)
    assert np.all(np.isfinite(r)) and abs(float(r[120, 160]) - 1.5 / math.cos(math.radians(3))) < 0.01
    expected = _grey(texture.sample(y, z))
    seen = _grey(img)
    win = cv2.createHanningWindow((320, 240), cv2.CV_32F)
    (dx, dy), response = cv2.phaseCorrelate(expected, seen, win)
    assert math.hypot(dx, dy) < 0.5 and response > 0.1
    # seen from 5 cm further along the wall, the wall moves 0.05 / 1.5 * f = 11.4 px left
    y2, z2, _ = wall_hits((pose[0], pose[1] + 0.05, pose[2], pose[3]), cam.a, cam.b)
    (dx, dy), _ = cv2.phaseCorrelate(_grey(texture.sample(y2, z2)), seen, win)
    assert abs(dx - 0.05 / 1.5 * cam.k.fx) < 1.0 and abs(dy) < 0.5
    # the lamp lights unevenly: the corrected image is flatter than the raw one
    assert img[:, :40].mean() < img[:, 140:180].mean()


def test_registration_of_a_pair_with_a_known_offset(texture: WallTexture) -> None:
    cam = WallCamera(texture)
    rng = np.random.default_rng(2)
    a, b = (-1.5, 1.0, 1.5, 0.0), (-1.5, 1.25, 1.62, 0.0)  # 25 cm right, 12 cm down
    ia, ib = cam.render(a, rng), cam.render(b, rng)
    field = illumination.flat_field([ia, ib])
    det = registration.Detector()
    fa = det.detect(illumination.grey_u8(illumination.correct(ia, field)))
    fb = det.detect(illumination.grey_u8(illumination.correct(ib, field)))
    pair = det.match(fa, fb, (240, 320), 0, 1, True)
    assert isinstance(pair, registration.Pair), pair
    shift = apply(pair.h, np.array([[160.0, 120.0]]))[0] - [160.0, 120.0]
    f = cam.k.fx
    assert abs(shift[0] - 0.25 / 1.5 * f) < 0.5 and abs(shift[1] - 0.12 / 1.5 * f) < 0.5
    truth = np.array([pose_from_world(*a), pose_from_world(*b)])
    err = accuracy.registration_errors([pair], truth, KK)
    assert err[0] < 0.5
    # a pair that does not overlap is refused with the reason
    ic = cam.render((-1.5, 3.0, 2.8, 0.0), rng)
    fc = det.detect(illumination.grey_u8(illumination.correct(ic, field)))
    assert isinstance(det.match(fa, fc, (240, 320), 0, 2, False), str)


def _pair(ti: np.ndarray, tj: np.ndarray, i: int, j: int, rng: np.random.Generator,
          noise: float = 0.2) -> registration.Pair:
    """A pair with the exact correspondences of the true poses, plus pixel noise."""
    h = accuracy.true_pair_homography(ti, tj, KK)
    pj = rng.uniform([20, 20], [300, 220], (60, 2))
    pi = apply(h, pj)
    inside = (pi[:, 0] > 0) & (pi[:, 0] < 319) & (pi[:, 1] > 0) & (pi[:, 1] < 239)
    pj, pi = pj[inside][:16], pi[inside][:16] + rng.normal(0, noise, (min(16, inside.sum()), 2))
    return registration.Pair(i, j, h, pi, pj, len(pi), j == i + 1)


def test_global_alignment_closes_a_synthetic_loop() -> None:
    rng = np.random.default_rng(3)
    # a loop of 16 images around a 1 m x 0.6 m rectangle, back to the start
    corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 0.6), (0.0, 0.6)]
    pts = []
    for (y0, z0), (y1, z1) in zip(corners, corners[1:] + corners[:1]):
        for s in np.linspace(0, 1, 4, endpoint=False):
            pts.append((y0 + s * (y1 - y0), z0 + s * (z1 - z0)))
    n = len(pts)
    truth = np.array([(y, z, 1.5 + 0.03 * math.sin(i), 0.01 * math.cos(i))
                      for i, (y, z) in enumerate(pts)])
    pairs = [_pair(truth[i], truth[(i + 1) % n], i, (i + 1) % n, rng) for i in range(n)]
    pairs += [_pair(truth[i], truth[j], i, j, rng) for i, j in ((0, 3), (4, 7), (8, 11), (12, 15))]
    # the navigation data is off by 4 cm (1 sigma) at each image, with no common bias: the
    # answer is the truth
    noise = rng.normal(0, [0.04, 0.04, 0.01, 0.005], (n, 4))
    prior = truth + noise - noise.mean(axis=0)
    std = np.tile([0.04, 0.04, 0.01, 0.005], (n, 1))
    before = accuracy.position_errors(prior, truth, KK)
    got = alignment.align(prior, std, pairs, KK)
    after = accuracy.position_errors(got.poses, truth, KK)
    assert float(np.sqrt(np.mean(before**2))) > 0.03
    assert after.max() < 0.004, after
    assert got.rejected == []
    # navigation data that drifts (8 cm by the end of the loop): the loop's shape is still
    # right to a few mm once the common offset, which nothing can see, is taken out
    drift = prior + np.linspace(0, 1, n)[:, None] * [0.08, -0.05, 0.0, 0.0]
    got_d = alignment.align(drift, std, pairs, KK)
    shifted = got_d.poses - (got_d.poses - truth).mean(axis=0)
    assert accuracy.position_errors(shifted, truth, KK).max() < 0.005
    assert accuracy.position_errors(drift - (drift - truth).mean(axis=0), truth, KK).max() > 0.03
    # a wrong pair (a 30 cm slip) is rejected, not bent into the solution
    wrong = _pair(truth[2], truth[3], 2, 3, rng)
    wrong.pi = wrong.pi + [0.3 / 1.5 * KK.fx, 0.0]
    got2 = alignment.align(prior, std, pairs + [wrong], KK)
    assert (2, 3) in got2.rejected
    assert accuracy.position_errors(got2.poses, truth, KK).max() < 0.004


@pytest.fixture(scope="module")
def survey(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two vertical legs of 6 images, the navigation data a little off."""
    folder = tmp_path_factory.mktemp("run") / "run.images"
    rec = ImageRecorder(folder, seed=7, texture=SPEC)
    rng = np.random.default_rng(4)
    i = 0
    for y, zs in ((1.0, np.linspace(1.0, 2.0, 6)), (1.6, np.linspace(2.0, 1.0, 6))):
        for z in zs:
            pose = (-1.5 + rng.normal(0, 0.02), y + rng.normal(0, 0.01), float(z),
                    float(rng.normal(0, 0.01)))
            nav = {"nav_x": pose[0], "nav_y": pose[1] + rng.normal(0, 0.02),
                   "nav_z": pose[2] + rng.normal(0, 0.02), "nav_psi": pose[3],
                   "nav_std_x": 0.02, "nav_std_y": 0.02, "nav_std_z": 0.02,
                   "nav_std_psi": 0.005, "wall_distance": -pose[0], "wall_distance_std": 0.01,
                   "wall_heading": pose[3], "wall_heading_std": 0.005}
            rec.record(i * 0.87, pose, nav)
            i += 1
    rec.set_plan([(1.0, 1.0), (1.6, 2.0), (2.8, 2.0)])  # planned further than flown
    # two damaged frames: a black one (lost) and a saturated one
    cv2.imwrite(str(folder / "00003.png"), np.zeros((240, 320, 3), np.uint8))
    cv2.imwrite(str(folder / "00008.png"), np.full((240, 320, 3), 255, np.uint8))
    return folder


def test_damaged_images_are_set_aside_and_reported(survey: Path) -> None:
    result = build.build(survey, mm_per_px=8.0, compare_without_prior=False)
    assert set(result.skipped) == {3, 8}
    assert "black" in result.skipped[3] and "saturated" in result.skipped[8]
    f = result.figures
    assert f["images"] == 12 and f["used"] == 10 and f["set_aside"] == 2 and f["pairs_registered"] >= 8
    lines = build.summary_lines(result, build.write(result, survey.parent / "run"))
    assert any("set aside 2 images: #3 black" in line for line in lines), lines
    # nothing of them in the mosaic: no black and no white where images were blended
    seen = result.mosaic[result.mosaic.sum(axis=2) != 3 * 40]
    assert seen.size and seen.min() > 5 and np.percentile(seen, 99.9) < 250
    # the planned area beyond what was flown stays empty: the gap shows
    assert f["area_seen_m2"] < 0.9 * (f["wall_area_m2"][2] - f["wall_area_m2"][0]) * (
        f["wall_area_m2"][3] - f["wall_area_m2"][1])
    assert f["registration_error_px"]["max"] < 1.0
    assert f["alignment_error_mm"]["rms"] < 20.0
    assert f["mosaic_error_mm"]["rms"] < 20.0 and f["control_points"] >= 2


def test_mcl_mosaic_writes_the_mosaic_and_refuses_bad_input(survey: Path, tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "again"
    assert cli.main([str(survey), "--out", str(out), "--scale", "10", "--no-truth"]) == 0
    text = capsys.readouterr().out
    assert f"{out}.mosaic.png" in text
    mosaic = cv2.imread(f"{out}.mosaic.png")
    coverage = cv2.imread(f"{out}.coverage.png")
    assert mosaic is not None and coverage is not None and mosaic.shape[1] > 100
    assert cli.main([str(tmp_path / "nothing.jsonl")]) == 2
    err = capsys.readouterr().err
    assert "error:" in err and "Traceback" not in err and len(err.splitlines()) == 2
    assert cli.main([str(tmp_path)]) == 2  # a folder that is not a run's images
    with pytest.raises(SystemExit) as exc:
        cli.main([str(survey), "--scale", "0"])
    assert exc.value.code == 2


def test_homography_matches_the_projection() -> None:
    pose = np.array([2.0, 1.5, 1.4, 0.05])
    h = homography(pose, KK)
    px = np.array([[10.0, 20.0], [160.0, 120.0], [300.0, 200.0]])
    a, b = KK.slopes(px)
    from mosaic.projection import wall_points

    assert np.allclose(apply(h, px), wall_points(pose[None, :], a, b), atol=1e-6)


@pytest.mark.slow
def test_the_stack_keeps_its_images_and_mcl_run_reports_the_mosaic(tmp_path: Path) -> None:
    """The hook of ``mcl run``: the simulated stack's camera renders and writes each image
    with the navigation data of the instant; the report builds the mosaic beside the log."""
    from mosaic.hook import attach, report
    from vehicle.control.stack import IctineuStack, StackConfig

    stack = IctineuStack(StackConfig(seed=3, start=(-1.5, 2.0, 2.0, 0.0)))
    log = tmp_path / "run.jsonl"
    attach(stack, log)
    stack.sensors.camera.start(0.0)
    for _ in range(100):  # 5 s: six images, one every 0.87 s
        stack.tick()
    assert stack.images.count == 6 and stack.images.background  # written by a worker thread
    stack.images.flush()
    index = (tmp_path / "run.images" / "index.csv").read_text().splitlines()
    assert len(index) == 7 and index[0].startswith("index,t,file,x,y,z,psi,nav_x")
    said: list[str] = []
    report(stack, log, said.append)
    text = "\n".join(said)
    assert f"{tmp_path / 'run.mosaic.png'}" in text and "built from 6 of 6 images" in text
    assert (tmp_path / "run.coverage.png").exists() and (tmp_path / "run.mosaic.json").exists()


def test_open_water_is_set_aside_as_textureless(texture: WallTexture) -> None:
    cam = WallCamera(texture)
    rng = np.random.default_rng(5)
    water = cam.render((-8.0, 1.0, 1.0, 0.0), rng)  # the wall beyond the 4 m visibility
    wall = cam.render((-1.5, 1.0, 1.0, 0.0), rng)
    field = illumination.flat_field([water, wall])
    assert illumination.damaged(water) is None  # not black, not saturated: just water
    why = illumination.textureless(illumination.correct(water, field))
    assert why is not None and why.startswith("no texture")
    assert illumination.textureless(illumination.correct(wall, field)) is None


def test_the_written_mosaic_and_coverage_map_carry_the_walls_coordinates(survey: Path) -> None:
    """Issue 25: a crack is located from the picture: both PNGs frame the canvas with the
    wall's coordinates and a grid whose lines lie where the metres say."""
    import json

    result = build.build(survey, mm_per_px=8.0, compare_without_prior=False)
    paths = build.write(result, survey.parent / "framed")
    picture = json.loads(paths["figures"].read_text())["picture"]
    c = result.canvas
    mosaic = cv2.imread(str(paths["mosaic"]))
    coverage = cv2.imread(str(paths["coverage"]))
    left, top = picture["left"], picture["top"]
    assert mosaic.shape[0] > c.rows + top and mosaic.shape[1] > c.cols + left
    assert coverage.shape[1] == mosaic.shape[1] and coverage.shape[0] > mosaic.shape[0]
    assert picture["y_lines"] and picture["z_lines"] and picture["px_per_m"] == 125.0
    for y, column in picture["y_lines"].items():
        assert column == left + round((float(y) - c.y0) / c.s - 0.5)
        for image in (mosaic, coverage):  # the tick under the picture, in both
            assert image[top + c.rows + 3, column].max() == 0
    # off the grid lines, the mosaic's pixels are the blended canvas's
    lined = set(picture["y_lines"].values())
    free = next(col for col in range(left + 5, left + c.cols) if col not in lined
                and col - 1 not in lined and col + 1 not in lined)
    rows = [r for r in range(top, top + c.rows) if r not in set(picture["z_lines"].values())]
    assert np.array_equal(mosaic[rows, free], result.mosaic[np.array(rows) - top, free - left])


@pytest.mark.parametrize("curvature", [0.0, 0.02])
def test_the_camera_works_the_wall_out_by_column_as_it_would_pixel_by_pixel(
        texture: WallTexture, curvature: float) -> None:
    """render() meets the wall once a column (a ray's horizontal slope is its column's): the
    images are the same, bit for bit, as with the rays' slopes given for every pixel —
    the wall filling the view, and seen in part (beyond the visibility, past its edge)."""
    by_column, by_pixel = WallCamera(texture, curvature), WallCamera(texture, curvature)
    by_pixel.a_row, by_pixel.b_column = by_pixel.a, by_pixel.b
    poses = [(-1.5, 1.0, 1.2, 0.0), (-2.0, 2.0, 1.5, 0.3), (-3.8, 1.5, 1.0, 0.6),
             (-1.0, -0.5, 0.3, -1.2), (-0.5, 2.0, 1.0, 1.45)]
    ra, rb = np.random.default_rng(4), np.random.default_rng(4)
    partial = 0
    for pose in poses:
        _, _, r = wall_hits(pose, by_pixel.a, by_pixel.b, curvature)
        partial += not bool((np.isfinite(r) & (r <= by_pixel.visibility)).all())
        assert np.array_equal(by_column.render(pose, ra), by_pixel.render(pose, rb)), pose
    assert partial >= 2  # both routes of render() taken


@pytest.mark.slow
def test_the_ground_truth_texture_made_ahead_is_the_one_measured_against(survey: Path) -> None:
    """mcl run makes the wall's texture while the camera's worker writes its last images and
    hands it to build(): the figures are those of the texture made inside, and another
    texture handed in would be measured against (so the one handed in is the one used)."""
    from concurrent.futures import Future

    def made(spec: TextureSpec) -> Future[WallTexture | None]:
        done: Future[WallTexture | None] = Future()
        done.set_result(accuracy.truth_texture({"texture": dataclasses.asdict(spec)}))
        return done

    inside = build.build(survey, mm_per_px=8.0, compare_without_prior=False)
    ahead = build.build(survey, mm_per_px=8.0, compare_without_prior=False, texture=made(SPEC))
    other = build.build(survey, mm_per_px=8.0, compare_without_prior=False,
                        texture=made(dataclasses.replace(SPEC, seed=8)))
    assert ahead.figures["mosaic_error_mm"] == inside.figures["mosaic_error_mm"]
    assert other.figures.get("mosaic_error_mm") != inside.figures["mosaic_error_mm"]
