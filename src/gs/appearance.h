#pragma once

#include <vector>

namespace pano4d {

// Per-frame appearance: an affine colour transform c' = A c + b per
// training frame (A 3x3, b 3), applied to the render before the loss, so
// that the exposure and white balance of each frame (each camera of a rig,
// a phone's auto exposure) are explained by the frame's transform instead
// of being averaged into the Gaussians' colours. 12 floats per frame: A
// row-major, then b. The identity is the transform of a frame whose colours
// the Gaussians hold as they are (renders for new views use it, or the
// transform of a training frame taken by the same camera).
inline constexpr int kAppearanceWidth = 12;

// The identity transform's 12 floats.
std::vector<float> IdentityAppearance();

// out[p] = A rgb[p] + b for every pixel of an H x W x 3 image; `out` is
// resized to rgb's size.
void ApplyAppearance(const float* transform, const std::vector<float>& rgb,
                     std::vector<float>* out);

// Backward of ApplyAppearance: from dL/dout, dL/drgb = A^T dL/dout into
// `d_rgb` (resized) and dL/dA, dL/db added to `d_transform` (12 floats).
// Sums over pixels in double, in blocks of pixels summed in order: the
// same whatever the thread count.
void ApplyAppearanceBackward(const float* transform,
                             const std::vector<float>& rgb,
                             const std::vector<float>& d_out,
                             std::vector<float>* d_rgb, float* d_transform);

// The regulariser weight x (|A - I|^2 + |b|^2), which keeps each transform
// near the identity (the Gaussians' colours and the transforms share a
// global gain, which this fixes); its gradient is added to `d_transform`.
double AppearanceRegulariser(const float* transform, double weight,
                             float* d_transform);

}  // namespace pano4d
