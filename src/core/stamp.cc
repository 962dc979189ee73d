#include "src/core/stamp.h"

#include <system_error>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

nlohmann::json Facts(const fs::path& file) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(file, ec);
  const fs::file_time_type time = fs::last_write_time(file, ec);
  if (ec) return nullptr;
  return {{"size", size},
          {"mtime_ns", static_cast<std::int64_t>(
                           std::chrono::duration_cast<std::chrono::nanoseconds>(
                               time.time_since_epoch())
                               .count())}};
}

}  // namespace

StageInputs& StageInputs::Option(const std::string& key, nlohmann::json value) {
  json_["options"][key] = std::move(value);
  return *this;
}

StageInputs& StageInputs::File(const fs::path& path) {
  const auto key = [&](const fs::path& p) {
    const fs::path absolute = fs::absolute(p).lexically_normal();
    const fs::path relative =
        absolute.lexically_relative(fs::absolute(root_).lexically_normal());
    const bool inside =
        !root_.empty() && !relative.empty() && *relative.begin() != "..";
    return (inside ? relative : absolute).generic_string();
  };
  nlohmann::json& files = json_["files"];
  std::error_code ec;
  // A workspace inside the folder (a dataset's) is not its input, nor are
  // pano4d's own files when the folder is the workspace.
  const auto skipped = [&](const fs::path& dir) {
    std::error_code e;
    return !root_.empty() && (fs::equivalent(dir, root_, e) ||
                              fs::equivalent(dir, root_ / "pano4d", e));
  };
  if (fs::is_directory(path, ec)) {
    const auto options = fs::directory_options::follow_directory_symlink;
    for (fs::recursive_directory_iterator it(path, options, ec), end;
         !ec && it != end; it.increment(ec)) {
      if (it->is_directory(ec)) {
        if (skipped(it->path())) it.disable_recursion_pending();
      } else if (it->is_regular_file(ec)) {
        files[key(it->path())] = Facts(it->path());
      }
    }
    if (ec) throw Error::In(path.string(), "cannot be listed: " + ec.message());
  } else {
    files[key(path)] = fs::exists(path, ec) ? Facts(path) : nullptr;
  }
  return *this;
}

std::optional<std::string> InputsDifference(const nlohmann::json& stamped,
                                            const nlohmann::json& now) {
  const nlohmann::json options = stamped.value("options", nlohmann::json());
  if (const std::optional<JsonDifference> d =
          FirstDifference(options, now.at("options"))) {
    return "option " + d->path + " was " + JsonValueForMessage(d->first) +
           ", now " + JsonValueForMessage(d->second);
  }
  const nlohmann::json before = stamped.value("files", nlohmann::json());
  if (!before.is_object()) return std::string("the stamp lists no files");
  for (const auto& [name, facts] : now.at("files").items()) {
    if (!before.contains(name)) return name + " is new";
    if (before[name] == facts) continue;
    if (facts.is_null()) return name + " is gone";
    return name + " changed";
  }
  for (const auto& [name, facts] : before.items()) {
    if (!now["files"].contains(name)) return name + " is gone";
  }
  return std::nullopt;
}

StageStamp::StageStamp(const Workspace& workspace, std::string stage)
    : path_(workspace.stamps() / (stage + ".json")) {}

std::optional<std::string> StageStamp::StaleReason(
    const StageInputs& inputs) const {
  if (!fs::exists(path_))
    return "no stamp: it has not completed in this workspace";
  const nlohmann::json stamp = nlohmann::json::parse(
      ReadTextFile(path_), nullptr, /*allow_exceptions=*/false);
  if (!stamp.is_object()) return path_.string() + " is not a stamp";
  return InputsDifference(stamp, inputs.json());
}

void StageStamp::Remove() const {
  std::error_code ec;
  fs::remove(path_, ec);
  if (ec) throw Error::In(path_.string(), "cannot be removed: " + ec.message());
}

void StageStamp::Write(const StageInputs& inputs) const {
  WriteFileAtomically(path_, inputs.json().dump(1) + "\n");
}

}  // namespace pano4d
