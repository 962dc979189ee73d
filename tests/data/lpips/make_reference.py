#!/usr/bin/python3
"""Reference outputs for tests/evaluation/lpips_test.cc, with Debian's
python3-torch and python3-torchvision.

The network has AlexNet's topology exactly (checked below against
torchvision.models.alexnet().features: every kernel, stride, padding and pool)
but narrow channels, with random weights from a fixed seed, so that the
fixture stays small while every step of the plumbing is exercised: the
ScalingLayer, conv/ReLU/max-pool slices, lpips.normalize_tensor, the squared
difference, the 1x1 linear heads, bilinear upsampling (align_corners=False)
and DyCheck's masked mean. The forward pass follows lpips/lpips.py
(LPIPS.forward with spatial=True) and DyCheck's get_compute_lpips. The real
alex.pth heads are not on these machines, so the heads are random too.
Run once; the outputs are committed:
  tests/data/lpips/make_reference.py tests/data/lpips
"""
import json
import os
import sys

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
import torchvision

out = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(__file__)
torch.manual_seed(20261122)
WIDTHS = [8, 12, 16, 12, 12]  # AlexNet: 64, 192, 384, 256, 256

# AlexNet's feature topology, from torchvision itself.
reference = torchvision.models.alexnet().features
convs = [m for m in reference if isinstance(m, nn.Conv2d)]
pools = [i for i, m in enumerate(reference) if isinstance(m, nn.MaxPool2d)]
assert [(c.kernel_size, c.stride, c.padding) for c in convs] == [
    ((11, 11), (4, 4), (2, 2)), ((5, 5), (1, 1), (2, 2)), ((3, 3), (1, 1), (1, 1)),
    ((3, 3), (1, 1), (1, 1)), ((3, 3), (1, 1), (1, 1))]
assert pools == [2, 5, 12] and all(reference[i].kernel_size == 3 and reference[i].stride == 2 for i in pools)

weights, in_ch = {}, 3
for i, (c, w) in enumerate(zip(convs, WIDTHS)):
    k = c.kernel_size[0]
    weights[f"conv{i + 1}.weight"] = (torch.randn(w, in_ch, k, k) * (2.0 / (in_ch * k * k)) ** 0.5).float()
    weights[f"conv{i + 1}.bias"] = (torch.randn(w) * 0.1).float()
    weights[f"lin{i}.weight"] = (torch.rand(1, w, 1, 1) * 0.2).float()  # learned heads are >= 0
    in_ch = w


def features(x):
    # LPIPS's alexnet slices: relu1..relu5 (pools before conv2 and conv3).
    outs = []
    for i in range(5):
        if i in (1, 2):
            x = F.max_pool2d(x, kernel_size=3, stride=2)
        c = convs[i]
        x = F.relu(F.conv2d(x, weights[f"conv{i + 1}.weight"], weights[f"conv{i + 1}.bias"],
                            stride=c.stride, padding=c.padding))
        outs.append(x)
    return outs


def lpips_map(img0, img1):
    shift = torch.tensor([-.030, -.088, -.188]).view(1, 3, 1, 1)
    scale = torch.tensor([.458, .448, .450]).view(1, 3, 1, 1)
    t0 = torch.from_numpy(img0).permute(2, 0, 1)[None].float() * 2 - 1  # im2tensor(factor=1/2)
    t1 = torch.from_numpy(img1).permute(2, 0, 1)[None].float() * 2 - 1
    f0, f1 = features((t0 - shift) / scale), features((t1 - shift) / scale)
    total = 0
    for i in range(5):
        n0 = f0[i] / (torch.sqrt(torch.sum(f0[i] ** 2, dim=1, keepdim=True)) + 1e-10)
        n1 = f1[i] / (torch.sqrt(torch.sum(f1[i] ** 2, dim=1, keepdim=True)) + 1e-10)
        lin = F.conv2d((n0 - n1) ** 2, weights[f"lin{i}.weight"])
        total = total + F.interpolate(lin, size=t0.shape[2:], mode="bilinear", align_corners=False)
    return total[0, 0].double().numpy()


def dycheck_lpips(img0, img1, mask=None):
    if mask is None:
        mask = np.ones_like(img0[..., :1])
    m = lpips_map(img0 * mask, img1 * mask)[..., None]
    return float((m * mask).sum() / max(mask.sum(), 1e-6))


H, W = 72, 96
rng = np.random.default_rng(7)
yy, xx = np.mgrid[0:H, 0:W]
a8 = np.stack([np.clip(128 + 90 * np.sin(xx / 7.0 + c) * np.cos(yy / 9.0) + rng.normal(0, 12, (H, W)), 0, 255)
               for c in range(3)], -1).astype(np.uint8)
b8 = np.clip(a8.astype(int) + rng.integers(-30, 31, a8.shape), 0, 255).astype(np.uint8)
b8[20:40, 50:80] = 30  # a dark patch: a local difference
mask = np.zeros((H, W, 1), np.uint8)
mask[10:60, 5:70] = 1

for name, t in weights.items():
    np.save(os.path.join(out, f"{name}.npy"), t.numpy().astype("<f4"))
np.save(os.path.join(out, "a.npy"), a8)
np.save(os.path.join(out, "b.npy"), b8)
np.save(os.path.join(out, "mask.npy"), mask)
a, b, m = a8 / 255.0, b8 / 255.0, mask.astype(np.float64)
full_map = lpips_map(a, b)
expected = {
    "lpips": dycheck_lpips(a, b),
    "lpips_masked": dycheck_lpips(a, b, m),
    "lpips_unseen": dycheck_lpips(a, b, 1 - m),
    "map_samples": [[int(y), int(x), float(full_map[y, x])] for y, x in [(0, 0), (30, 60), (71, 95), (5, 40)]],
    "torch": torch.__version__,
}
with open(os.path.join(out, "expected.json"), "w") as f:
    json.dump(expected, f, indent=2)
    f.write("\n")
print(json.dumps(expected, indent=1))
