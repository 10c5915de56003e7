// The transfer f_r(s, s') chain(s) (N20) as propagation over voxel clusters evaluates it: the
// copies it reads in slot order (Transfer), the per-pair table built once per pool under a
// byte budget (propagation/pair_table.hpp), and the links propagation calls.
#pragma once

#include "segpath/algorithms/filtering/pool.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/pair_table.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace segpath::filtering {

/// f_r(s, s') chain(s) (N20) as propagation evaluates it, from copies in slot order
/// (propagation/clustering.hpp), gathered once per pool: per ending slot what the BSDF needs
/// of the ending segment, per starting slot the starting direction; only for the clusters
/// that are not factorised (propagation never evaluates the link in the others), which then
/// map slots to records. Memory: at most sizeof(Ending) + sizeof(Vec3) + 8 bytes per segment.
template <LightSampledScene Scn>
struct Transfer {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  struct Ending {
    SurfacePoint<T> y;
    Vec3<T> outgoing;  ///< -last_direction: from y back along the segment
    S chain;
  };
  std::vector<Ending> ending;
  std::vector<Vec3<T>> starting_direction;
  std::vector<std::uint32_t> ending_record, starting_record;  ///< slot -> record; empty: the identity

  template <class P = SerialFor>
  void build(const Pool<T, S>& pool, const Clustering<T>& clustering, std::span<const std::uint8_t> factorised = {},
             const P& parallel_for = {}) {
    const auto clusters = clustering.clusters();
    const bool compact = !factorised.empty();
    // Records: the slots of the clusters kept, in slot order.
    std::vector<std::uint32_t> first_ending, first_starting;
    std::size_t endings = clustering.ending_slot_count(), startings = clustering.starting_slot_count();
    if (compact) {
      first_ending.resize(clusters.size());
      first_starting.resize(clusters.size());
      endings = startings = 0;
      for (std::size_t c = 0; c < clusters.size(); ++c) {
        first_ending[c] = std::uint32_t(endings);
        first_starting[c] = std::uint32_t(startings);
        if (factorised[c]) continue;
        endings += clusters[c].ending_count();
        startings += clusters[c].starting_count();
      }
    }
    ending.resize(endings);
    starting_direction.resize(startings);
    ending_record.assign(compact ? clustering.ending_slot_count() : 0, 0);
    starting_record.assign(compact ? clustering.starting_slot_count() : 0, 0);
    const auto ending_segment = clustering.ending_segments();
    const auto starting_segment = clustering.starting_segments();
    parallel_for(clusters.size(), [&](std::size_t c) {
      if (compact && factorised[c]) return;
      const Cluster<T>& cl = clusters[c];
      for (std::uint32_t q = 0; q < cl.starting_count(); ++q) {
        const std::uint32_t j = cl.slot + q, record = compact ? first_starting[c] + q : j;
        if (compact) starting_record[j] = record;
        starting_direction[record] = pool.first_direction[starting_segment[j]];
      }
      const std::uint32_t first = cl.ending_slot(cl.middle);
      for (std::uint32_t q = 0; q < cl.ending_count(); ++q) {
        const std::uint32_t i = first + q, record = compact ? first_ending[c] + q : i;
        if (compact) ending_record[i] = record;
        const std::uint32_t s = ending_segment[i];
        ending[record] = Ending{pool.segments[s].y, -pool.last_direction[s], pool.chain[s]};
      }
    });
  }
  /// At most.
  [[nodiscard]] static constexpr std::size_t bytes_per_segment() noexcept {
    return sizeof(Ending) + sizeof(Vec3<T>) + 2 * sizeof(std::uint32_t);
  }
  [[nodiscard]] std::size_t bytes() const noexcept {
    return ending.capacity() * sizeof(Ending) + starting_direction.capacity() * sizeof(Vec3<T>) +
           (ending_record.capacity() + starting_record.capacity()) * sizeof(std::uint32_t);
  }
};

/// The link(s, s', i, j) of propagation over a Transfer.
template <LightSampledScene Scn>
struct TransferLink {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  decltype(std::declval<const Scn&>().bsdf()) bsdf;
  const Transfer<Scn>& transfer;
  S operator()(std::uint32_t, std::uint32_t, std::uint32_t i, std::uint32_t j) const noexcept {
    const auto& e = transfer.ending[transfer.ending_record.empty() ? i : transfer.ending_record[i]];
    const auto& w = transfer.starting_direction[transfer.starting_record.empty() ? j : transfer.starting_record[j]];
    return bsdf.eval(BsdfQuery<T>{e.y, e.outgoing, w, Transport::radiance}) * e.chain;
  }
};

/// A TransferLink that reads the pairs a PairTable holds (built once per pool, under
/// FilteringOptions::transfer_cache_bytes).
template <LightSampledScene Scn>
struct CachedTransferLink {
  using S = typename Scn::Spectrum;
  TransferLink<Scn> link;
  const PairTable<S>& cache;
  S operator()(std::uint32_t s, std::uint32_t sp, std::uint32_t i, std::uint32_t j) const noexcept {
    const S* cached = cache.find(i, j);
    return cached ? *cached : link(s, sp, i, j);
  }
};

}  // namespace segpath::filtering
