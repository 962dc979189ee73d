#!/usr/bin/python3
"""Writes the .npy fixtures of tests/core/npy_test.cc with NumPy itself, so the
C++ reader is checked against the reference writer. Run once with Debian's
python3-numpy (`apt-get install python3-numpy`); the outputs are committed.
Usage: tests/data/npy/make_fixtures.py tests/data/npy
"""
import io
import os
import sys

import numpy as np

out = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(__file__)


def save(name, array, version=None):
    path = os.path.join(out, name)
    if version is None:
        np.save(path, array)
    else:
        with open(path, "wb") as f:
            np.lib.format.write_array(f, array, version=version)


save("f4_2x3.npy", np.arange(6, dtype="<f4").reshape(2, 3) / 4)
save("f8_big_endian.npy", np.array([1.5, -2.25, 1e300], dtype=">f8"))
save("u1_2x3x2.npy", np.arange(12, dtype=np.uint8).reshape(2, 3, 2))
save("i8_scalar.npy", np.array(-7, dtype="<i8"))
save("bool_1d.npy", np.array([True, False, True]))
save("i2_v2.npy", np.array([[-3, 4]], dtype="<i2"), version=(2, 0))
save("f8_fortran.npy", np.asfortranarray(np.arange(6, dtype="<f8").reshape(2, 3)))
save("c8_complex.npy", np.array([1 + 2j], dtype="<c8"))
# An LLFF poses_bounds.npy as Nvidia Dynamic Scenes ships it: N x 17 float64.
save("poses_bounds_2x17.npy", np.arange(34, dtype="<f8").reshape(2, 17) * 0.5)
