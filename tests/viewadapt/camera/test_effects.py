"""viewadapt.camera.effects: each camera effect does what it says, and only when asked."""

import cv2
import numpy as np
import pytest

from viewadapt.camera.effects import EFFECT_KEYS, CameraEffects, apply_camera_effects

NEUTRAL = CameraEffects().draw(np.random.default_rng(0))


def _image(seed=0, shape=(96, 80, 3)):
    rng = np.random.default_rng(seed)
    smooth = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), 3)
    smooth = (smooth - smooth.min()) / (smooth.max() - smooth.min())
    return (40 + 170 * smooth).astype(np.uint8)


def _with(**kw):
    return dict(NEUTRAL, **kw)


def test_neutral_parameters_leave_the_image_as_it_is():
    img = _image()
    assert set(EFFECT_KEYS) <= set(NEUTRAL)
    out = apply_camera_effects(img, NEUTRAL)
    assert np.array_equal(out, img) and out is not img


def test_draws_are_reproducible_and_within_their_ranges():
    fx = CameraEffects(blur_sigma=(0.5, 1.0), noise_sigma=(2, 4), jpeg_quality=(40, 60),
                       white_balance=0.1, exposure=(0.8, 1.2), downscale=(0.5, 0.9))
    a = [fx.draw(np.random.default_rng([3, i])) for i in range(200)]
    assert a[7] == fx.draw(np.random.default_rng([3, 7]))
    assert all(0.5 <= d["blur_sigma"] <= 1.0 and 2 <= d["noise_sigma"] <= 4
               and 40 <= d["jpeg_quality"] <= 60 and 0.5 <= d["downscale"] <= 0.9
               for d in a)
    for d in a:
        g = np.asarray(d["gains"])
        assert 0.8 <= g[1] <= 1.2 and np.all(np.abs(g[[0, 2]] / g[1] - 1) <= 0.1 + 1e-12)
    # one effect's range does not move the others' draws
    other = CameraEffects(blur_sigma=(0.5, 1.0), noise_sigma=(2, 4), jpeg_quality=(40, 60),
                          white_balance=0.1, exposure=(0.8, 1.2), downscale=(0.5, 0.9),
                          vignetting=(0.1, 0.2))
    b = other.draw(np.random.default_rng([3, 0]))
    assert b["blur_sigma"] == a[0]["blur_sigma"] and b["gains"] == a[0]["gains"]


def test_blur_lowers_the_gradient_energy_and_keeps_the_mean():
    img = np.random.default_rng(1).integers(40, 210, (96, 80, 3), dtype=np.uint8)
    out = apply_camera_effects(img, _with(blur_sigma=2.0))
    energy = lambda x: np.abs(np.diff(x.astype(float), axis=1)).mean()     # noqa: E731
    assert energy(out) < 0.6 * energy(img)
    assert abs(out.mean() - img.mean()) < 1.0


def test_vignetting_darkens_the_corners_not_the_centre():
    img = np.full((101, 81, 3), 200, np.uint8)
    out = apply_camera_effects(img, _with(vignetting=0.4)).astype(float)
    assert out[50, 40].mean() == pytest.approx(200, abs=1)
    assert out[0, 0].mean() == pytest.approx(120, abs=2)              # 200 (1 - 0.4)


def test_gains_scale_each_channel():
    img = np.full((8, 8, 3), 100, np.uint8)
    out = apply_camera_effects(img, _with(gains=[1.2, 1.0, 0.5]))
    assert out[0, 0].tolist() == [120, 100, 50]


def test_noise_has_the_asked_strength_and_grows_with_the_signal():
    dark = np.full((200, 200, 3), 30, np.uint8)
    mid = np.full((200, 200, 3), 128, np.uint8)
    p = _with(noise_sigma=6.0, noise_seed=5)
    sd_mid = (apply_camera_effects(mid, p).astype(float) - 128).std()
    sd_dark = (apply_camera_effects(dark, p).astype(float) - 30).std()
    assert sd_mid == pytest.approx(6.0 * np.sqrt(128 / 127.5), rel=0.05)
    assert sd_dark < 0.6 * sd_mid
    assert np.array_equal(apply_camera_effects(mid, p), apply_camera_effects(mid, p))
    assert not np.array_equal(apply_camera_effects(mid, p),
                              apply_camera_effects(mid, dict(p, noise_seed=6)))


def test_gamma_brightens_the_mid_tones_when_above_one():
    img = np.full((4, 4, 3), 64, np.uint8)
    out = apply_camera_effects(img, _with(gamma=2.0))
    assert out[0, 0, 0] == round(255 * (64 / 255) ** 0.5)


def test_low_resolution_and_jpeg_remove_fine_detail():
    rng = np.random.default_rng(2)
    img = np.repeat(np.repeat(rng.integers(0, 256, (48, 40, 3), dtype=np.uint8), 2, 0), 2, 1)
    fine = lambda x: np.abs(x[:, 1:].astype(float) - x[:, :-1]).mean()     # noqa: E731
    low = apply_camera_effects(img, _with(downscale=0.5))
    assert low.shape == img.shape and fine(low) < fine(img)
    q10 = apply_camera_effects(img, _with(jpeg_quality=10))
    q95 = apply_camera_effects(img, _with(jpeg_quality=95))
    err = lambda x: np.abs(x.astype(float) - img).mean()                 # noqa: E731
    assert err(q95) < err(q10) and err(q10) > 5


@pytest.mark.parametrize("kw, match", [
    (dict(blur_sigma=(1.0, 0.5)), "blur_sigma must be a range"),
    (dict(noise_sigma=(0.0, float("inf"))), "noise_sigma"),
    (dict(downscale=(0.0, 1.0)), "downscale"),
    (dict(white_balance=-0.1), "white_balance"),
    (dict(jpeg_quality=(0, 50)), "jpeg_quality"),
])
def test_bad_ranges_are_refused_in_one_line(kw, match):
    with pytest.raises(ValueError, match=match):
        CameraEffects(**kw)


def test_only_8_bit_rgb_images_are_taken():
    for bad in (np.zeros((4, 4), np.uint8), np.zeros((4, 4, 3), np.float32)):
        with pytest.raises(ValueError, match=r"\(M, N, 3\) uint8 RGB"):
            apply_camera_effects(bad, NEUTRAL)
