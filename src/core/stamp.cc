#include "src/core/stamp.h"

#include <system_error>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/log.h"

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

nlohmann::json Section(const nlohmann::json& record, const char* key) {
  return record.is_object() ? record.value(key, nlohmann::json::object())
                            : nlohmann::json::object();
}

}  // namespace

std::string StageRecord::Key(const fs::path& p) const {
  const fs::path absolute = fs::absolute(p).lexically_normal();
  const fs::path relative =
      absolute.lexically_relative(fs::absolute(root_).lexically_normal());
  const bool inside =
      !root_.empty() && !relative.empty() && *relative.begin() != "..";
  return (inside ? relative : absolute).generic_string();
}

StageRecord& StageRecord::Option(const std::string& key, nlohmann::json value) {
  json_["options"][key] = std::move(value);
  return *this;
}

StageRecord& StageRecord::File(const fs::path& path) {
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
        files[Key(it->path())] = Facts(it->path());
      }
    }
    if (ec) throw Error::In(path.string(), "cannot be listed: " + ec.message());
  } else {
    files[Key(path)] = fs::exists(path, ec) ? Facts(path) : nullptr;
  }
  return *this;
}

StageRecord& StageRecord::Content(const std::string& name,
                                  const std::string& fingerprint) {
  json_["contents"][name] = fingerprint;
  return *this;
}

StageRecord& StageRecord::Output(const fs::path& path) {
  json_["outputs"].push_back(Key(path));
  return *this;
}

std::optional<std::string> RecordDifference(const nlohmann::json& stamped,
                                            const nlohmann::json& now) {
  if (const std::optional<JsonDifference> d = FirstDifference(
          Section(stamped, "options"), Section(now, "options"))) {
    return "option " + d->path + " was " + JsonValueForMessage(d->first) +
           ", now " + JsonValueForMessage(d->second);
  }
  const nlohmann::json before = Section(stamped, "files");
  const nlohmann::json after = Section(now, "files");
  for (const auto& [name, facts] : after.items()) {
    if (!before.contains(name)) return name + " is new";
    if (before[name] == facts) continue;
    if (facts.is_null()) return name + " is gone";
    return name + " changed";
  }
  for (const auto& [name, facts] : before.items()) {
    if (!after.contains(name)) return name + " is gone";
  }
  const nlohmann::json held = Section(stamped, "contents");
  const nlohmann::json contents = Section(now, "contents");
  for (const auto& [name, fingerprint] : contents.items()) {
    if (held.value(name, nlohmann::json()) != fingerprint)
      return name + " changed";
  }
  return std::nullopt;
}

StageStamp::StageStamp(const Workspace& workspace, std::string stage)
    : stage_(std::move(stage)),
      root_(workspace.root()),
      path_(workspace.stamps() / (stage_ + ".json")) {}

std::optional<std::string> StageStamp::StaleReason(
    const StageRecord& now) const {
  if (!fs::exists(path_))
    return "no stamp: it has not completed in this workspace";
  const nlohmann::json stamp = nlohmann::json::parse(
      ReadTextFile(path_), nullptr, /*allow_exceptions=*/false);
  if (!stamp.is_object()) return path_.string() + " is not a stamp";
  if (std::optional<std::string> why = RecordDifference(stamp, now.json()))
    return why;
  const nlohmann::json outputs = stamp.value("outputs", nlohmann::json());
  if (!outputs.is_array()) return std::nullopt;
  for (const nlohmann::json& output : outputs) {
    if (!output.is_string()) return path_.string() + " is not a stamp";
    const fs::path path(output.get<std::string>());
    std::error_code ec;
    if (!fs::exists(path.is_absolute() ? path : root_ / path, ec))
      return "its output " + output.get<std::string>() + " is gone";
  }
  return std::nullopt;
}

std::optional<std::string> StageStamp::Decide(
    const StageRecord& now, const std::optional<std::string>& forced) const {
  const std::optional<std::string> why = forced ? forced : StaleReason(now);
  if (why)
    PANO4D_LOG(kInfo) << stage_ << " runs: " << *why;
  else
    PANO4D_LOG(kInfo) << stage_ << " reused: nothing it read changed";
  return why;
}

double StageStamp::Seconds() const {
  std::error_code ec;
  if (!fs::exists(path_, ec)) return 0;
  const nlohmann::json stamp = nlohmann::json::parse(
      ReadTextFile(path_), nullptr, /*allow_exceptions=*/false);
  if (!stamp.is_object()) return 0;
  const nlohmann::json seconds = stamp.value("seconds", nlohmann::json());
  return seconds.is_number() ? seconds.get<double>() : 0.0;
}

void StageStamp::Remove() const {
  std::error_code ec;
  fs::remove(path_, ec);
  if (ec) throw Error::In(path_.string(), "cannot be removed: " + ec.message());
}

void StageStamp::Write(const StageRecord& record, double seconds) const {
  nlohmann::json stamp = record.json();
  stamp["seconds"] = seconds;
  WriteFileAtomically(path_, stamp.dump(1) + "\n");
}

}  // namespace pano4d
