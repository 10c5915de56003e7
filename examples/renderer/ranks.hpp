// The processes of a render: MPI_COMM_WORLD's ranks when segpath-render is built with MPI
// (CMake defines SEGPATH_RENDER_MPI where it found Debian's OpenMPI), else one process. Only
// what the renderer's loop needs, every call from the main thread (MPI_THREAD_FUNNELED): the
// worker threads never see MPI.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstddef>
#include <span>
#include <stdexcept>
#include <string>

#if SEGPATH_RENDER_MPI
#include <mpi.h>
#endif

namespace renderer {

class Ranks {
 public:
  /// Starts MPI (when built with it); argc and argv as main got them.
  /// Started without a launcher (no mpirun, srun or mpiexec environment), the process is one
  /// rank and skips MPI_Init: a singleton MPI start costs about 0.4 s here.
  Ranks(int& argc, char**& argv) {
#if SEGPATH_RENDER_MPI
    if (!launched_by_mpi()) return;
    mpi_ = true;
    int provided = 0;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
#else
    (void)argc;
    (void)argv;
#endif
  }
  ~Ranks() {
#if SEGPATH_RENDER_MPI
    if (mpi_) MPI_Finalize();
#endif
  }

  /// Whether an MPI launcher started this process: Open MPI's mpirun, MPICH's Hydra (PMI) or a
  /// PMIx launcher such as Slurm's srun set these.
  [[nodiscard]] static bool launched_by_mpi() noexcept {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK"})
      if (std::getenv(name) != nullptr) return true;
    return false;
  }
  Ranks(const Ranks&) = delete;
  Ranks& operator=(const Ranks&) = delete;

  [[nodiscard]] int rank() const noexcept { return rank_; }
  [[nodiscard]] int size() const noexcept { return size_; }
  /// Rank 0 reads the checkpoint, adds the iterations in order, writes the images and prints.
  [[nodiscard]] bool root() const noexcept { return rank_ == 0; }

  /// Rank 0's value, on every rank.
  [[nodiscard]] std::uint64_t broadcast(std::uint64_t value) const {
#if SEGPATH_RENDER_MPI
    if (size_ > 1) MPI_Bcast(&value, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
#endif
    return value;
  }
  /// True on every rank when `value` is true on every rank.
  [[nodiscard]] bool all(bool value) const {
    int v = value ? 1 : 0;
#if SEGPATH_RENDER_MPI
    if (size_ > 1) MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_INT, MPI_LAND, MPI_COMM_WORLD);
#endif
    return v != 0;
  }
  /// The first rank whose `value` differs from rank 0's, or -1 when all equal it.
  [[nodiscard]] int first_differing(std::uint64_t value) const {
    const std::uint64_t root_value = broadcast(value);
    int first = value == root_value ? size_ : rank_;
#if SEGPATH_RENDER_MPI
    if (size_ > 1) MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
#endif
    return first == size_ ? -1 : first;
  }
  /// Sends `bytes` to rank 0, which receives them with receive() (in messages of at most 1 GiB:
  /// MPI counts are ints).
  void send_to_root(std::span<const std::byte> bytes) const {
#if SEGPATH_RENDER_MPI
    for (std::size_t at = 0; at < bytes.size(); at += max_message)
      MPI_Send(bytes.data() + at, int(std::min(max_message, bytes.size() - at)), MPI_BYTE, 0, tag, MPI_COMM_WORLD);
#else
    (void)bytes;
    throw std::logic_error("renderer::Ranks: one process has no rank to send to");
#endif
  }
  /// Returns when a message of rank `from` has started to arrive (MPI_Probe): the time spent here
  /// is waiting for that rank, the receive() after it is the transfer.
  void wait_for(int from) const {
#if SEGPATH_RENDER_MPI
    MPI_Probe(from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
#else
    (void)from;
#endif
  }
  /// Receives into `bytes` (of the size sent) what rank `from` sent with send_to_root().
  void receive(int from, std::span<std::byte> bytes) const {
#if SEGPATH_RENDER_MPI
    for (std::size_t at = 0; at < bytes.size(); at += max_message)
      MPI_Recv(bytes.data() + at, int(std::min(max_message, bytes.size() - at)), MPI_BYTE, from, tag, MPI_COMM_WORLD,
               MPI_STATUS_IGNORE);
#else
    (void)from;
    (void)bytes;
    throw std::logic_error("renderer::Ranks: one process has no rank to receive from");
#endif
  }
  /// Rank `from`'s `text`, on rank 0 (other ranks get their own back); every rank calls it.
  [[nodiscard]] std::string text_of(int from, std::string text) const {
    if (from == 0 || size_ == 1) return text;
    std::uint64_t length = text.size();
    if (rank_ == from) {
      send_to_root(std::as_bytes(std::span(&length, 1)));
      send_to_root(std::as_bytes(std::span(text.data(), text.size())));
    } else if (root()) {
      receive(from, std::as_writable_bytes(std::span(&length, 1)));
      text.assign(length, '\0');
      receive(from, std::as_writable_bytes(std::span(text.data(), text.size())));
    }
    return text;
  }

  /// Ends every rank after an error only this rank saw (the others would wait for it forever).
  [[noreturn]] void abort_all(int code) const {
#if SEGPATH_RENDER_MPI
    if (size_ > 1) MPI_Abort(MPI_COMM_WORLD, code);
#endif
    std::exit(code);
  }

 private:
  static constexpr int tag = 1;
  static constexpr std::size_t max_message = std::size_t(1) << 30;
  int rank_ = 0;
  int size_ = 1;
  bool mpi_ = false;  ///< MPI_Init was called
};

}  // namespace renderer
