#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace pano4d {

// Adam (Kingma & Ba) over parameter groups that share rows: every group
// holds `rows` x `width` floats (e.g. means: width 3, SH: width 3 K), and
// densification and pruning add and remove rows in all groups at once, as
// the 3D Gaussian splatting optimiser does with its per-parameter state.
struct AdamOptions {
  double beta1 = 0.9;
  double beta2 = 0.999;
  // 3DGS's epsilon: gradients of far Gaussians are tiny, and 1e-8 would
  // damp their steps.
  double epsilon = 1e-15;
  void Check() const;  // throws pano4d::Error naming the field
};

struct AdamStepStats {
  // Rows skipped because a gradient entry was NaN or infinite: their
  // parameters and moments are left as they were.
  std::int64_t skipped_rows = 0;
};

class Adam {
 public:
  explicit Adam(AdamOptions options = {});

  // Registers `params` (not owned; must outlive the optimiser) as a group
  // of rows of `width` floats with learning rate `lr`; returns its index.
  // Throws pano4d::Error when the size is not rows x width with the rows of
  // the groups already added.
  int AddGroup(std::string name, std::vector<float>* params, int width,
               double lr);
  void SetLearningRate(int group, double lr);
  double learning_rate(int group) const { return groups_[group].lr; }
  const std::string& name(int group) const { return groups_[group].name; }
  int groups() const { return static_cast<int>(groups_.size()); }
  std::int64_t rows() const { return rows_; }
  std::int64_t step() const { return step_; }

  // One update of every group with its gradient (same layout as its
  // parameters; an empty vector means "no gradient this step" and leaves
  // the group as it is).
  AdamStepStats Step(const std::vector<const std::vector<float>*>& gradients);

  // After the caller appended `count` rows to every group's parameters:
  // their moments start at zero.
  void AppendRows(std::int64_t count);
  // After the caller removed the rows whose keep[i] is 0 from every
  // group's parameters (in order): the moments follow.
  void KeepRows(const std::vector<std::uint8_t>& keep);

  // The moments of a group, for checkpoints.
  std::vector<float>& first_moment(int group) { return groups_[group].m; }
  std::vector<float>& second_moment(int group) { return groups_[group].v; }
  const std::vector<float>& first_moment(int group) const {
    return groups_[group].m;
  }
  const std::vector<float>& second_moment(int group) const {
    return groups_[group].v;
  }
  void set_step(std::int64_t step) { step_ = step; }
  // After a checkpoint replaced every group's parameters and moments with
  // arrays of another row count: takes the count from them. Returns what
  // does not fit (parameters of another row count, moments of another
  // size), empty when everything does: the file's content, which the
  // caller names.
  std::string RestoreRows();

 private:
  struct Group {
    std::string name;
    std::vector<float>* params;
    int width;
    double lr;
    std::vector<float> m, v;
  };
  void CheckSizes() const;

  AdamOptions options_;
  std::vector<Group> groups_;
  std::int64_t rows_ = 0;
  std::int64_t step_ = 0;
};

// 3DGS's learning-rate schedule: log-linear from lr_init at step 0 to
// lr_final at max_steps, constant after.
double ExponentialLearningRate(double lr_init, double lr_final,
                               std::int64_t step, std::int64_t max_steps);

}  // namespace pano4d
