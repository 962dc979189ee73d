#!/usr/bin/python3
"""Writes the LPIPS (v0.1, AlexNet) weights that `pano4d eval --lpips-weights`
reads: a folder of float32 .npy files conv1..conv5 .weight/.bias and
lin0..lin4 .weight. Run where PyTorch is available (Debian: python3-torch);
pano4d itself never runs Python.

  scripts/lpips_weights_from_torch.py --alexnet alexnet-owt-7be5be79.pth \
      --lin alex.pth --out lpips-alex-v0.1/

--alexnet: torchvision's ImageNet AlexNet state dict (what
  torchvision.models.alexnet(pretrained=True) downloads into the torch hub
  cache). --lin: the LPIPS linear heads, lpips/weights/v0.1/alex.pth from
  richzhang/PerceptualSimilarity (also shipped inside the `lpips` pip package).
"""
import argparse
import os

import numpy as np
import torch

# torchvision.models.alexnet().features: the convolutions' indices.
ALEXNET_CONVS = [0, 3, 6, 8, 10]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--alexnet", required=True, help="torchvision AlexNet state dict (.pth)")
    parser.add_argument("--lin", required=True, help="LPIPS v0.1 alex.pth (linear heads)")
    parser.add_argument("--out", required=True, help="output folder")
    args = parser.parse_args()

    backbone = torch.load(args.alexnet, map_location="cpu")
    heads = torch.load(args.lin, map_location="cpu")
    os.makedirs(args.out, exist_ok=True)

    def save(name, tensor):
        np.save(os.path.join(args.out, name + ".npy"), tensor.detach().float().numpy().astype("<f4"))

    for i, index in enumerate(ALEXNET_CONVS):
        for part in ("weight", "bias"):
            key = f"features.{index}.{part}"
            if key not in backbone:
                raise SystemExit(f"{args.alexnet}: no '{key}'; is this torchvision's AlexNet?")
            save(f"conv{i + 1}.{part}", backbone[key])
    for i in range(5):
        # NetLinLayer is Sequential(Dropout, Conv2d) in v0.1 with dropout,
        # Sequential(Conv2d) without it.
        key = next((k for k in (f"lin{i}.model.1.weight", f"lin{i}.model.0.weight") if k in heads), None)
        if key is None:
            raise SystemExit(f"{args.lin}: no lin{i}.model.*.weight; is this LPIPS's alex.pth?")
        save(f"lin{i}.weight", heads[key])
    print(f"wrote LPIPS AlexNet weights to {args.out}")


if __name__ == "__main__":
    main()
