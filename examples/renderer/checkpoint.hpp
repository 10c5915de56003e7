// segpath-render's checkpoints (--checkpoint, --resume): the sum of the iterations so far, the
// index of the next one and the counters, so that a render killed at any moment continues to the
// image an uninterrupted render gives, bit for bit. A file is written to FILE.tmp, synced and
// renamed over FILE (rename is atomic), so FILE is always the last complete checkpoint.
//
// Format (native byte order; a marker rejects a file from a machine of the other order):
//   "segpath-checkpoint\n", u32 version, u32 byte-order marker,
//   u64 length + the render's image options ("key=value\n" lines, options.hpp),
//   u32 width, u32 height, u64 next iteration, u64 paths, u64 rays,
//   u64 drop reason count + one u64 per reason,
//   width x height x 3 f64 (the sum, RGB), u64 FNV-1a hash of every byte before it.
#pragma once

#include "integrators.hpp"

#include <algorithm>
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
#include <fcntl.h>
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

/// The largest image side a checkpoint may have (segpath-render's --width/--height limit).
inline constexpr std::uint32_t checkpoint_max_side = 16384;
/// The largest iteration count a checkpoint may hold (far beyond any render; a bound that keeps
/// a corrupt count from wrapping the iteration index).
inline constexpr std::uint64_t checkpoint_max_iterations = std::uint64_t(1) << 40;

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
/// "--key: A in <a_name>, B in <b_name>" (or "--k1 A in <a_name>, --k2 B in <b_name>" when the
/// options differ themselves); empty when they are the same.
[[nodiscard]] inline std::string first_difference(std::string_view a, std::string_view b, const std::string& a_name,
                                                  const std::string& b_name) {
  const auto la = detail::option_lines(a), lb = detail::option_lines(b);
  for (std::size_t i = 0; i < std::max(la.size(), lb.size()); ++i) {
    if (i < la.size() && i < lb.size() && la[i] == lb[i]) continue;
    const std::string ka = i < la.size() ? la[i].first : "", kb = i < lb.size() ? lb[i].first : "";
    const std::string va = i < la.size() ? la[i].second : "(none)", vb = i < lb.size() ? lb[i].second : "(none)";
    if (ka == kb) return "--" + ka + ": " + va + " in " + a_name + ", " + vb + " in " + b_name;
    const auto option = [](const std::string& k, const std::string& v) { return k.empty() ? std::string("nothing") : "--" + k + " " + v; };
    return option(ka, va) + " in " + a_name + ", " + option(kb, vb) + " in " + b_name;
  }
  return {};
}

/// Writes a checkpoint of `sum` (with the options, iteration count and counters) to `path`
/// atomically: FILE.tmp, streamed in 1 MB pieces with a running hash, fsync, rename, fsync of
/// the directory. Throws std::runtime_error naming the file on failure.
inline void write_checkpoint(const std::string& path, const std::string& options, std::uint64_t iterations,
                             const Stats& stats, const Accumulator& sum) {
  const std::string temporary = path + ".tmp";
  std::FILE* f = std::fopen(temporary.c_str(), "wb");
  const auto fail = [&](const char* what) {
    const std::string reason = std::strerror(errno);
    if (f) std::fclose(f);
    std::remove(temporary.c_str());
    throw std::runtime_error("--checkpoint " + path + ": cannot " + what + " " + temporary + " (" + reason + ")");
  };
  if (!f) fail("create");
  std::uint64_t hash = detail::fnv1a({});
  std::string buffer;
  const auto flush = [&] {
    hash = detail::fnv1a(buffer, hash);
    if (std::fwrite(buffer.data(), 1, buffer.size(), f) != buffer.size()) fail("write");
    buffer.clear();
  };
  buffer = detail::checkpoint_magic;
  detail::put(buffer, detail::checkpoint_version);
  detail::put(buffer, detail::byte_order_marker);
  detail::put(buffer, std::uint64_t(options.size()));
  buffer += options;
  detail::put(buffer, sum.width());
  detail::put(buffer, sum.height());
  detail::put(buffer, iterations);
  detail::put(buffer, stats.paths);
  detail::put(buffer, stats.rays);
  detail::put(buffer, std::uint64_t(segpath::drop_reason_count));
  for (const std::uint64_t n : stats.dropped.counts) detail::put(buffer, n);
  for (const auto& p : sum.pixels()) {
    detail::put(buffer, p.r);
    detail::put(buffer, p.g);
    detail::put(buffer, p.b);
    if (buffer.size() >= (1u << 20)) flush();
  }
  flush();
  detail::put(buffer, hash);
  if (std::fwrite(buffer.data(), 1, buffer.size(), f) != buffer.size() || std::fflush(f) != 0 || ::fsync(::fileno(f)) != 0)
    fail("write");
  const int closed = std::fclose(f);
  f = nullptr;
  if (closed != 0) fail("write");
  if (std::rename(temporary.c_str(), path.c_str()) != 0) fail("rename");
  // The rename itself survives a crash only once the directory is synced (best effort).
  std::filesystem::path directory = std::filesystem::path(path).parent_path();
  if (directory.empty()) directory = ".";
  if (const int fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY); fd >= 0) {
    (void)::fsync(fd);
    ::close(fd);
  }
}

/// Reads the checkpoint at `path`, streaming it into the sum (memory: the sum and 1 MB); throws
/// std::runtime_error with a one-line reason (missing, not a checkpoint, another byte order or
/// version, an impossible size, truncated, corrupt).
[[nodiscard]] inline Checkpoint read_checkpoint(const std::string& path) {
  const auto fail = [&](const std::string& why) -> void { throw std::runtime_error("--resume " + path + ": " + why); };
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) fail("no such file");
  const std::uint64_t file_size = std::filesystem::file_size(path, ec);
  if (ec) fail("cannot read it");
  std::ifstream in(path, std::ios::binary);
  std::uint64_t hash = detail::fnv1a({});
  std::uint64_t consumed = 0;
  std::string piece;
  // Reads n bytes (hashed), or fails as truncated.
  const auto take = [&](std::size_t n) -> const std::string& {
    piece.resize(n);
    if (n > file_size - consumed || !in.read(piece.data(), std::streamsize(n))) fail("the checkpoint is truncated");
    consumed += n;
    hash = detail::fnv1a(piece, hash);
    return piece;
  };
  const auto get = [&]<class V>(V) {
    V value;
    std::memcpy(&value, take(sizeof value).data(), sizeof value);
    return value;
  };
  if (file_size < detail::checkpoint_magic.size() || take(detail::checkpoint_magic.size()) != detail::checkpoint_magic)
    fail("not a segpath-render checkpoint");
  if (const auto v = get(std::uint32_t()); v != detail::checkpoint_version)
    fail("checkpoint version " + std::to_string(v) + ", this renderer reads " + std::to_string(detail::checkpoint_version));
  if (get(std::uint32_t()) != detail::byte_order_marker) fail("written on a machine of another byte order (or corrupt)");
  Checkpoint c;
  const auto options_size = get(std::uint64_t());
  if (options_size > (1u << 20)) fail("the checkpoint is corrupt (its options are " + std::to_string(options_size) + " bytes)");
  c.options = take(options_size);
  const auto width = get(std::uint32_t()), height = get(std::uint32_t());
  c.iterations = get(std::uint64_t());
  c.stats.paths = get(std::uint64_t());
  c.stats.rays = get(std::uint64_t());
  if (get(std::uint64_t()) != segpath::drop_reason_count) fail("written by a renderer with other drop reasons");
  for (std::uint64_t& n : c.stats.dropped.counts) n = get(std::uint64_t());
  // Sizes checked before anything is allocated for them (the hash is checked at the end).
  if (width == 0 || height == 0 || width > checkpoint_max_side || height > checkpoint_max_side ||
      file_size - consumed != std::uint64_t(width) * height * 3 * sizeof(double) + sizeof(std::uint64_t))
    fail("the checkpoint is corrupt (its size does not match its " + std::to_string(width) + " x " + std::to_string(height) +
         " pixels)");
  if (c.iterations > checkpoint_max_iterations) fail("the checkpoint is corrupt (" + std::to_string(c.iterations) + " iterations)");
  c.sum = Accumulator(width, height);
  constexpr std::uint32_t block = 1 << 15;  // pixels per read
  for (std::uint32_t p = 0; p < c.sum.pixel_count(); p += block) {
    const std::uint32_t n = std::min(block, c.sum.pixel_count() - p);
    const char* bytes = take(std::size_t(n) * 3 * sizeof(double)).data();
    for (std::uint32_t i = 0; i < n; ++i) {
      double rgb[3];
      std::memcpy(rgb, bytes + std::size_t(i) * sizeof rgb, sizeof rgb);
      c.sum[p + i] = segpath::Rgb<double>(rgb[0], rgb[1], rgb[2]);
    }
  }
  const std::uint64_t computed = hash;
  if (get(std::uint64_t()) != computed) fail("the checkpoint is corrupt (its checksum does not match)");
  return c;
}

}  // namespace renderer
