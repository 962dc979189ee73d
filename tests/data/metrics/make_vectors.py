#!/usr/bin/python3
"""Reference values for tests/evaluation/metrics_test.cc.

Unmasked PSNR and SSIM come from scikit-image (Debian python3-skimage):
  peak_signal_noise_ratio(data_range=1)
  structural_similarity(gaussian_weights=True, sigma=1.5,
                        use_sample_covariance=False, data_range=1, channel_axis=-1)
Masked PSNR and SSIM come from a NumPy port of DyCheck's
dycheck/core/metrics/image.py (compute_psnr, compute_ssim with partial
convolution) and dycheck/nn/functional/common.py (masked_mean), quirk
included: windows wholly outside the mask count as 1.0 in the mean. The
strict variant averages only windows whose final partial-convolution count is
non-zero. Run once; the outputs are committed:
  tests/data/metrics/make_vectors.py tests/data/metrics
"""
import json
import os
import sys

import numpy as np
from scipy.signal import convolve2d
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

out = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(__file__)
H, W = 32, 40
rng = np.random.default_rng(20261122)


def dycheck_psnr(a, b, mask):
    mse = (a - b) ** 2
    m = np.broadcast_to(mask, mse.shape)
    return float(-10.0 / np.log(10.0) * np.log((mse * m).sum() / max(m.sum(), 1e-6)))


def dycheck_ssim(a, b, mask, strict=False):
    mask = mask[..., 0]
    size, sigma = 11, 1.5
    hw = size // 2
    shift = (2 * hw - size + 1) / 2
    f = np.exp(-0.5 * ((np.arange(size) - hw + shift) / sigma) ** 2)
    f /= f.sum()

    def conv(z, m, filt):
        z_ = convolve2d(z * m, filt, mode="valid")
        m_ = convolve2d(m, np.ones_like(filt), mode="valid")
        return np.where(m_ != 0, z_ * np.ones_like(filt).sum() / np.where(m_ != 0, m_, 1), 0), (
            m_ != 0
        ).astype(z.dtype)

    def blur(z, m):  # along W (filt[None, :]) first, then H (filt[:, None])
        outs, last = [], None
        for c in range(z.shape[2]):
            z1, m1 = conv(z[..., c], m, f[None, :])
            z2, m2 = conv(z1, m1, f[:, None])
            outs.append(z2)
            last = m2
        return np.stack(outs, axis=-1), last

    mu0, valid = blur(a, mask)
    mu1, _ = blur(b, mask)
    s00 = np.maximum(0.0, blur(a * a, mask)[0] - mu0 * mu0)
    s11 = np.maximum(0.0, blur(b * b, mask)[0] - mu1 * mu1)
    s01 = blur(a * b, mask)[0] - mu0 * mu1
    s01 = np.sign(s01) * np.minimum(np.sqrt(s00 * s11), np.abs(s01))
    c1, c2 = 0.01**2, 0.03**2
    ssim_map = ((2 * mu0 * mu1 + c1) * (2 * s01 + c2)) / ((mu0**2 + mu1**2 + c1) * (s00 + s11 + c2))
    if strict:
        return float(ssim_map[valid != 0].mean())
    return float(ssim_map.mean())


yy, xx = np.mgrid[0:H, 0:W]
smooth = np.stack([0.5 + 0.4 * np.sin(xx / 6.0 + c) * np.cos(yy / 5.0 - c) for c in range(3)], -1)
cases = {
    "flat": (np.full((H, W, 3), 128, np.uint8), np.full((H, W, 3), 131, np.uint8)),
    "noisy": None,
    "smooth": (
        np.clip(smooth * 255, 0, 255).astype(np.uint8),
        np.clip(np.roll(smooth, 2, axis=1) * 255 * 0.95 + 6, 0, 255).astype(np.uint8),
    ),
    "extreme": (np.zeros((H, W, 3), np.uint8), np.full((H, W, 3), 255, np.uint8)),
}
noisy_a = rng.integers(0, 256, (H, W, 3), dtype=np.uint8)
noisy_b = np.clip(noisy_a.astype(int) + rng.integers(-40, 41, (H, W, 3)), 0, 255).astype(np.uint8)
cases["noisy"] = (noisy_a, noisy_b)

# A mask with a solid blob and an empty band wider than a window, so that the
# quirk (windows wholly outside the mask count as 1) matters.
mask = np.zeros((H, W, 1), np.uint8)
mask[4:26, 3:18] = 1
mask[20:30, 30:38] = 1
mask |= (rng.random((H, W, 1)) < 0.05).astype(np.uint8)
mask[:, 18:30] = 0
np.save(os.path.join(out, "mask.npy"), mask)

expected = {}
for name, (a8, b8) in cases.items():
    np.save(os.path.join(out, f"{name}_a.npy"), a8)
    np.save(os.path.join(out, f"{name}_b.npy"), b8)
    a, b = a8 / 255.0, b8 / 255.0
    m = mask.astype(np.float64)
    expected[name] = {
        "psnr": float(peak_signal_noise_ratio(a, b, data_range=1)),
        "ssim": float(
            structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                                  use_sample_covariance=False, data_range=1, channel_axis=-1)
        ),
        "psnr_full_mask_dycheck": dycheck_psnr(a, b, np.ones_like(m)),
        "ssim_full_mask_dycheck": dycheck_ssim(a, b, np.ones_like(m)),
        "masked_psnr": dycheck_psnr(a, b, m),
        "masked_ssim": dycheck_ssim(a, b, m),
        "masked_ssim_strict": dycheck_ssim(a, b, m, strict=True),
        "unseen_psnr": dycheck_psnr(a, b, 1 - m),
        "unseen_ssim": dycheck_ssim(a, b, 1 - m),
        "unseen_ssim_strict": dycheck_ssim(a, b, 1 - m, strict=True),
    }
with open(os.path.join(out, "expected.json"), "w") as f:
    json.dump(expected, f, indent=2, sort_keys=True)
    f.write("\n")
print(json.dumps(expected, indent=1))
