"""Defect pixels by the EMVA 1288 rules, on planted defects and on a real recording."""

from pathlib import Path

import numpy as np
import pytest

from radiosim.defects import ROBUST_SIGMA, find_defect_pixels
from radiosim.errors import RadiosimError


def test_the_robust_sigma_is_that_of_a_gaussian():
    """1.4826 = 1 / Φ⁻¹(0.75): the median absolute deviation of a normal sample × it is σ."""
    from scipy.stats import norm

    assert ROBUST_SIGMA == pytest.approx(1 / norm.ppf(0.75), rel=1e-12)


def test_planted_defects_on_a_scene_with_edges_are_found_and_nothing_else():
    """A 200 × 300 scene with a hot disc and a gradient (edges are no defects), 16 frames of
    5 DN noise; planted: 7 hot (+60 DN: 48 σ of a 16-frame mean's 1.25 DN), 5 cold, 3 dead
    (stuck), 4 noisy (× 8 noise). With k = 6 a good pixel is flagged with probability
    ~2e-9 per test: none of the 60 000 is."""
    rng = np.random.default_rng(12)
    y, x = np.mgrid[0:200, 0:300]
    scene = 1000.0 + 2.0 * x + 1500.0 * ((x - 150) ** 2 + (y - 100) ** 2 < 60**2)
    frames = scene + rng.normal(0.0, 5.0, (16, 200, 300))
    planted = {kind: [tuple(p) for p in rng.choice(np.argwhere(np.ones((190, 290))) + 5,
                                                   size=n, replace=False)]
               for kind, n in (("hot", 7), ("cold", 5), ("dead", 3), ("noisy", 4))}
    for i, j in planted["hot"]:
        frames[:, i, j] += 60.0
    for i, j in planted["cold"]:
        frames[:, i, j] -= 60.0
    for i, j in planted["dead"]:
        frames[:, i, j] = scene[i, j]
    for i, j in planted["noisy"]:
        frames[:, i, j] = scene[i, j] + rng.normal(0.0, 40.0, 16)
    found = find_defect_pixels(frames)
    for kind, where in planted.items():
        got = {tuple(p) for p in np.argwhere(getattr(found, kind))}
        assert got == set(where), (kind, got ^ set(where))
    # The spread is the 16-frame mean's noise σ = 5/√16 DN seen through a 5 × 5 median that
    # includes the pixel: below σ (the median shares the pixel: √(1 + π/50 − 2/25) = 0.99 σ on
    # a flat scene, √(1 + π/10 − 2/5) = 0.96 σ where a steep gradient leaves the median to the
    # centre column's five values), and the median absolute deviation of that peaked
    # distribution reads lower by up to ~10 %: above 0.75 σ.
    sigma = 5.0 / 4.0
    assert 0.75 * sigma < found.spread < 1.0 * sigma


def test_the_real_jade_frame_shows_its_hot_pixels():
    """The Jade recording's hot pixels near 10 870 DN, which a plain threshold (9 000 DN,
    far above its 6 800 DN disc) counts independently, are among the hot pixels found at
    any k, and are all of them at k = 500 (4 000 DN above neighbours whose noise is 2 DN);
    its raw fixed pattern's milder outliers show at k = 6."""
    from radiosim.io import read_recording

    r = read_recording(Path(__file__).parent / "data" / "ptw" / "LWIR-BBref-150C-150us.ptw")
    plain = r.frames().mean(axis=0) > 9_000
    assert 10 <= plain.sum() <= 20
    assert np.array_equal(r.defect_pixels().hot & plain, plain)
    strict = r.defect_pixels(k=500.0)
    assert np.array_equal(strict.hot, plain) and strict.counts()["cold"] == 0


@pytest.mark.parametrize("frames, said", [
    (np.zeros((3, 4, 40)), "at least 5 × 5 pixels"),
    (np.full((3, 10, 10), np.nan), "finite counts"),
    (np.zeros(10), "shape (10,)"),
])
def test_bad_frames_are_refused(frames, said):
    with pytest.raises(RadiosimError, match=None) as info:
        find_defect_pixels(frames)
    assert said in str(info.value)


def test_no_frames_or_a_k_as_text_is_refused():
    with pytest.raises(RadiosimError, match="at least one frame"):
        find_defect_pixels(np.zeros((0, 10, 10)))
    with pytest.raises(RadiosimError, match="k must be a finite number"):
        find_defect_pixels(np.zeros((2, 10, 10)), k="6")
