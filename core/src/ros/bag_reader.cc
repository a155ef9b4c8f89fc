#include "skidimm/io/ros/bag_reader.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstring>
#include <fstream>

#include "bag_storage.h"
#include "mcap_format.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {

namespace fs = std::filesystem;

namespace {

bool has_extension(const fs::path& path, const char* extension) { return path.extension() == extension; }

bool starts_with_mcap_magic(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  return in.read(magic, sizeof(magic)) && std::memcmp(magic, mcap::kMagic, sizeof(magic)) == 0;
}

std::string scalar(const YAML::Node& node, const char* key, const fs::path& file) {
  const YAML::Node value = node[key];
  if (!value) return "";
  if (!value.IsScalar()) throw LogError(file.string(), value.Mark().line + 1, std::string(key) + ": expected text");
  return value.as<std::string>();
}

}  // namespace

int BagReader::topic_index(const std::string& name) const {
  for (std::size_t i = 0; i < topics_.size(); ++i) {
    if (topics_[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

bool BagReader::is_bag(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return fs::exists(path / "metadata.yaml", ec);
  if (has_extension(path, ".mcap") || has_extension(path, ".db3")) return true;
  return fs::is_regular_file(path, ec) && starts_with_mcap_magic(path);
}

std::string BagReader::unfinished_recording(const fs::path& directory) {
  std::error_code ec;
  if (!fs::is_directory(directory, ec) || fs::exists(directory / "metadata.yaml", ec)) return "";
  std::vector<std::string> found;
  bool sqlite = false;
  for (fs::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    if (!(has_extension(p, ".db3") || has_extension(p, ".mcap"))) continue;
    sqlite = sqlite || has_extension(p, ".db3");
    found.push_back(p.filename().string());
  }
  if (found.empty()) return "";
  std::sort(found.begin(), found.end());
  std::string listed;
  for (std::size_t i = 0; i < found.size() && i < 3; ++i) listed += (listed.empty() ? "" : ", ") + found[i];
  if (found.size() > 3) listed += " and " + std::to_string(found.size() - 3) + " more";
  return "it holds a bag's files (" + listed +
         ") but no metadata.yaml, which rosbag2 writes when a recording ends: a recording stopped hard? `ros2 bag "
         "reindex " +
         directory.string() + "` writes it" +
         (sqlite ? "" : "; an .mcap file can also be read alone, as a log of its own");
}

BagMetadata read_bag_metadata(const fs::path& file) {
  BagMetadata m;
  m.file = file;
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::Exception& e) {
    throw LogError(file.string(), e.mark.line + 1, "not a rosbag2 metadata file: " + e.msg);
  }
  const YAML::Node info = root.IsMap() ? root["rosbag2_bagfile_information"] : YAML::Node();
  if (!info || !info.IsMap()) {
    throw LogError(file.string(), 1, "expected rosbag2_bagfile_information: (the metadata.yaml rosbag2 writes)");
  }
  try {
    m.storage_identifier = scalar(info, "storage_identifier", file);
    m.compression_format = scalar(info, "compression_format", file);
    m.compression_mode = scalar(info, "compression_mode", file);
    const YAML::Node paths = info["relative_file_paths"];
    if (!paths || !paths.IsSequence() || paths.size() == 0) {
      throw LogError(file.string(), info.Mark().line + 1, "relative_file_paths: expected the list of the bag's files");
    }
    for (const YAML::Node& p : paths) {
      if (!p.IsScalar()) throw LogError(file.string(), p.Mark().line + 1, "relative_file_paths: expected file names");
      m.files.push_back(file.parent_path() / p.as<std::string>());
    }
  } catch (const YAML::Exception& e) {
    throw LogError(file.string(), e.mark.line + 1, e.msg);
  }
  std::transform(m.compression_mode.begin(), m.compression_mode.end(), m.compression_mode.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  if (m.storage_identifier.empty()) {
    const fs::path& first = m.files.front();
    m.storage_identifier = first.extension() == ".db3" ? "sqlite3" : "mcap";
  }
  return m;
}

std::unique_ptr<BagReader> BagReader::open(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    const fs::path metadata = path / "metadata.yaml";
    if (!fs::exists(metadata, ec)) {
      throw LogError(path.string(), 0,
                     "a directory without metadata.yaml is not a ROS 2 bag (rosbag2 writes metadata.yaml beside the "
                     "bag's files; `ros2 bag reindex` rewrites a lost one)");
    }
    BagMetadata m = read_bag_metadata(metadata);
    // A file of the bag's storage that the metadata does not list: a
    // recording whose metadata was written before its last split (or a stray
    // copy). Read as listed, the bag would end early without a word.
    for (fs::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
      const fs::path& p = it->path();
      if (!(has_extension(p, ".db3") || has_extension(p, ".mcap"))) continue;
      const bool listed =
          std::any_of(m.files.begin(), m.files.end(), [&](const fs::path& f) { return f.filename() == p.filename(); });
      if (!listed) {
        throw LogError(metadata.string(), 0,
                       "does not list " + p.filename().string() +
                           ", a bag file in its directory: the recording's last split, written after this metadata? "
                           "`ros2 bag reindex " +
                           path.string() +
                           "` rewrites the metadata with every file; or move "
                           "the file out to read the bag as listed");
      }
    }
    if (m.compression_mode == "FILE") {
      throw LogError(metadata.string(), 0,
                     "the bag's files are compressed whole (compression_mode: file), which skidimm does not read: "
                     "decompress them first (`ros2 bag decompress` or zstd -d, then fix relative_file_paths)");
    }
    for (const fs::path& f : m.files) {
      if (!fs::exists(f, ec)) throw LogError(metadata.string(), 0, "lists " + f.string() + ", which does not exist");
    }
    if (m.storage_identifier == "mcap") return open_mcap_bag(path, m.files);
    if (m.storage_identifier == "sqlite3") return open_sqlite_bag(path, m);
    throw LogError(metadata.string(), 0,
                   "storage_identifier '" + m.storage_identifier + "': skidimm reads mcap and sqlite3 bags");
  }
  if (!fs::exists(path, ec)) throw LogError(path.string(), 0, "no such file or directory");
  if (has_extension(path, ".db3")) {
    const fs::path metadata = path.parent_path() / "metadata.yaml";
    if (!fs::exists(metadata, ec)) {
      throw LogError(path.string(), 0,
                     "no metadata.yaml beside this .db3 file: rosbag2 writes one in the bag's directory, and it says "
                     "how the messages are stored (compression, split files). Give the bag's directory with its "
                     "metadata.yaml, or recreate it with `ros2 bag reindex " + path.parent_path().string() + "`");
    }
    BagMetadata m = read_bag_metadata(metadata);
    // The file given alone: the metadata's other files are not read.
    m.files = {path};
    return open_sqlite_bag(path, m);
  }
  return open_mcap_bag(path, {path});
}

}  // namespace ros
}  // namespace skidimm
