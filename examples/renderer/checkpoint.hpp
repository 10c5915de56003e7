// segpath-render's checkpoints (--checkpoint, --resume): the sum of the iterations so far, the
// index of the next one and the counters, so that a render killed at any moment continues to the
// image an uninterrupted render gives, bit for bit. A file is written whole to FILE.tmp, synced
// and renamed over FILE (rename is atomic), so FILE is always the last complete checkpoint.
//
// Format (native byte order; a marker rejects a file from a machine of the other order):
//   "segpath-checkpoint\n", u32 version, u32 byte-order marker,
//   u64 length + the render's image options ("key=value\n" lines, options.hpp),
//   u32 width, u32 height, u64 next iteration, u64 paths, u64 rays,
//   u64 drop reason count + one u64 per reason,
//   width x height x 3 f64 (the sum, RGB), u64 FNV-1a hash of every byte before it.
#pragma once

#include "integrators.hpp"

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unistd.h>
#include <vector>

namespace renderer {

/// What a checkpoint holds.
struct Checkpoint {
  std::string options;  ///< the image options of the render that wrote it
  std::uint64_t iterations = 0;  ///< iterations in the sum: the index of the next one
  Stats stats;          ///< paths, rays and drops of those iterations
  Accumulator sum{1, 1};
};

namespace detail {

inline constexpr std::string_view checkpoint_magic = "segpath-checkpoint\n";
inline constexpr std::uint32_t checkpoint_version = 1;
inline constexpr std::uint32_t byte_order_marker = 0x01020304u;

/// FNV-1a, 64 bits.
[[nodiscard]] inline std::uint64_t fnv1a(std::string_view bytes, std::uint64_t hash = 0xcbf29ce484222325ull) noexcept {
  for (const char c : bytes) {
    hash ^= std::uint8_t(c);
    hash *= 0x100000001b3ull;
  }
  return hash;
}

template <class V>
void put(std::string& out, const V& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

/// Reads the fields of a checkpoint in order; every read past the end is an error.
class CheckpointReader {
 public:
  CheckpointReader(std::string_view bytes, const std::string& path) : bytes_(bytes), path_(path) {}
  template <class V>
  V get() {
    V value;
    std::memcpy(&value, take(sizeof value).data(), sizeof value);
    return value;
  }
  std::string_view take(std::size_t n) {
    if (n > bytes_.size() - at_) throw std::runtime_error("--resume " + path_ + ": the checkpoint is truncated");
    const std::string_view s = bytes_.substr(at_, n);
    at_ += n;
    return s;
  }
  [[nodiscard]] std::size_t offset() const noexcept { return at_; }

 private:
  std::string_view bytes_;
  std::string path_;
  std::size_t at_ = 0;
};

/// "key=value" lines as (key, value) pairs.
[[nodiscard]] inline std::vector<std::pair<std::string, std::string>> option_lines(std::string_view text) {
  std::vector<std::pair<std::string, std::string>> lines;
  while (!text.empty()) {
    const std::size_t end = std::min(text.find('\n'), text.size());
    const std::string_view line = text.substr(0, end);
    const std::size_t eq = line.find('=');
    lines.emplace_back(std::string(line.substr(0, eq)), eq == line.npos ? std::string() : std::string(line.substr(eq + 1)));
    text.remove_prefix(std::min(end + 1, text.size()));
  }
  return lines;
}

}  // namespace detail

/// The first option that differs between two renders' image options `a` and `b`, as
/// "--key: A in <a_name>, B in <b_name>"; empty when they are the same.
[[nodiscard]] inline std::string first_difference(std::string_view a, std::string_view b, const std::string& a_name,
                                                  const std::string& b_name) {
  const auto la = detail::option_lines(a), lb = detail::option_lines(b);
  for (std::size_t i = 0; i < std::max(la.size(), lb.size()); ++i) {
    if (i < la.size() && i < lb.size() && la[i] == lb[i]) continue;
    const std::string key = i < lb.size() ? lb[i].first : la[i].first;
    const std::string va = i < la.size() ? la[i].second : "(none)", vb = i < lb.size() ? lb[i].second : "(none)";
    return "--" + key + ": " + va + " in " + a_name + ", " + vb + " in " + b_name;
  }
  return {};
}

/// Writes `c` to `path` atomically (FILE.tmp, fsync, rename); throws std::runtime_error naming
/// the file on failure.
inline void write_checkpoint(const std::string& path, const Checkpoint& c) {
  std::string bytes(detail::checkpoint_magic);
  detail::put(bytes, detail::checkpoint_version);
  detail::put(bytes, detail::byte_order_marker);
  detail::put(bytes, std::uint64_t(c.options.size()));
  bytes += c.options;
  detail::put(bytes, c.sum.width());
  detail::put(bytes, c.sum.height());
  detail::put(bytes, c.iterations);
  detail::put(bytes, c.stats.paths);
  detail::put(bytes, c.stats.rays);
  detail::put(bytes, std::uint64_t(segpath::drop_reason_count));
  for (const std::uint64_t n : c.stats.dropped.counts) detail::put(bytes, n);
  for (const auto& p : c.sum.pixels()) {
    detail::put(bytes, p.r);
    detail::put(bytes, p.g);
    detail::put(bytes, p.b);
  }
  detail::put(bytes, detail::fnv1a(bytes));

  const std::string temporary = path + ".tmp";
  const auto fail = [&](const char* what) {
    const std::string reason = std::strerror(errno);
    std::remove(temporary.c_str());
    throw std::runtime_error("--checkpoint " + path + ": cannot " + what + " " + temporary + " (" + reason + ")");
  };
  std::FILE* f = std::fopen(temporary.c_str(), "wb");
  if (!f) fail("create");
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size() && std::fflush(f) == 0 &&
                       ::fsync(::fileno(f)) == 0;
  if (std::fclose(f) != 0 || !written) fail("write");
  if (std::rename(temporary.c_str(), path.c_str()) != 0) fail("rename");
}

/// Reads the checkpoint at `path`; throws std::runtime_error with a one-line reason (missing,
/// not a checkpoint, another byte order or version, truncated, corrupt).
[[nodiscard]] inline Checkpoint read_checkpoint(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw std::runtime_error("--resume " + path + ": no such file");
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) throw std::runtime_error("--resume " + path + ": cannot read it");
  detail::CheckpointReader r(bytes, path);
  if (bytes.compare(0, detail::checkpoint_magic.size(), detail::checkpoint_magic) != 0)
    throw std::runtime_error("--resume " + path + ": not a segpath-render checkpoint");
  (void)r.take(detail::checkpoint_magic.size());
  if (const auto v = r.get<std::uint32_t>(); v != detail::checkpoint_version)
    throw std::runtime_error("--resume " + path + ": checkpoint version " + std::to_string(v) + ", this renderer reads " +
                             std::to_string(detail::checkpoint_version));
  if (r.get<std::uint32_t>() != detail::byte_order_marker)
    throw std::runtime_error("--resume " + path + ": written on a machine of another byte order (or corrupt)");
  // The hash first: every later field is then what the writer wrote.
  if (bytes.size() < r.offset() + sizeof(std::uint64_t)) throw std::runtime_error("--resume " + path + ": the checkpoint is truncated");
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - sizeof stored, sizeof stored);
  if (detail::fnv1a(std::string_view(bytes).substr(0, bytes.size() - sizeof stored)) != stored)
    throw std::runtime_error("--resume " + path + ": the checkpoint is corrupt (its checksum does not match)");

  Checkpoint c;
  c.options = std::string(r.take(r.get<std::uint64_t>()));
  const auto width = r.get<std::uint32_t>(), height = r.get<std::uint32_t>();
  c.iterations = r.get<std::uint64_t>();
  c.stats.paths = r.get<std::uint64_t>();
  c.stats.rays = r.get<std::uint64_t>();
  if (r.get<std::uint64_t>() != segpath::drop_reason_count)
    throw std::runtime_error("--resume " + path + ": written by a renderer with other drop reasons");
  for (std::uint64_t& n : c.stats.dropped.counts) n = r.get<std::uint64_t>();
  const std::uint64_t pixels = std::uint64_t(width) * height;
  if (width == 0 || height == 0 || bytes.size() - r.offset() != pixels * 3 * sizeof(double) + sizeof(std::uint64_t))
    throw std::runtime_error("--resume " + path + ": the checkpoint's size does not match its " + std::to_string(width) + " x " +
                             std::to_string(height) + " pixels");
  c.sum = Accumulator(width, height);
  for (std::uint32_t p = 0; p < c.sum.pixel_count(); ++p) {
    const double red = r.get<double>(), green = r.get<double>(), blue = r.get<double>();
    c.sum[p] = segpath::Rgb<double>(red, green, blue);
  }
  return c;
}

}  // namespace renderer
