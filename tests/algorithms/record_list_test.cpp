// A RecordList keeps of a record drawn from a parent only the end its own draw found and
// restores the other from the parent's pooled segment (algorithms/filtering/record_list.hpp):
// every field and both ends come back as pushed, for records without a parent, camera-born
// children (which start at their parent's y) and light-born ones (which end at their parent's x).
#include <segpath/algorithms/filtering/record_list.hpp>

#include <cstdint>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;
using namespace segpath::filtering;

namespace {

SurfacePoint<float> point(float k) {
  return SurfacePoint<float>{{k, 2 * k, -k}, {0, 0, 1}, {0, 1, 0}, std::uint32_t(k), std::uint32_t(10 * k), PointKind::surface};
}

bool same(const SurfacePoint<float>& a, const SurfacePoint<float>& b) {
  return a.position == b.position && a.normal == b.normal && a.shading_normal == b.shading_normal &&
         a.primitive_id == b.primitive_id && a.material_id == b.material_id && a.kind == b.kind;
}

}  // namespace

TEST_CASE("a record list restores the end a record shares with its parent", "[algorithms]") {
  // A camera path (sensor segment, successor, its next-event segment, a successor of that) and a
  // light path (light start, predecessor, its predecessor), interleaved as one list holds them.
  std::vector<Record<float, Rgb<float>>> drawn;
  auto add = [&](float x, float y, std::uint16_t flags, std::uint32_t parent) {
    Record<float, Rgb<float>> r;
    r.segment = {point(x), point(y)};
    r.first_direction = {x, 0, 1};
    r.last_direction = {0, y, 1};
    r.chain = Rgb<float>(x, y, 1);
    r.geometry = x + y, r.sensor_weight = 2 * x, r.density = 3 * y;
    r.pixel = std::uint32_t(x), r.parent = parent, r.flags = flags, r.pieces = std::uint16_t(y), r.next_event = x > 2;
    drawn.push_back(r);
  };
  add(1, 2, sensor_segment | camera_born, no_parent);     // 0
  add(2, 3, camera_born, 0);                              // 1: starts at 0's y
  add(20, 21, light_start, no_parent);                    // 2
  add(3, 4, camera_born, 1);                              // 3: next-event from 1's y
  add(19, 20, light_technique, 2);                        // 4: ends at 2's x
  add(3, 5, camera_born | camera_technique, 1);           // 5: starts at 1's y
  add(18, 19, 0, 4);                                      // 6: ends at 4's x
  RecordList<float, Rgb<float>> list;
  for (const auto& r : drawn) list.push_back(r);
  REQUIRE(list.size() == drawn.size());
  // Parentless records hold two ends, the others one.
  CHECK(list.capacity_bytes() - list.unfilled_bytes() ==
        drawn.size() * sizeof(RecordFields<float, Rgb<float>>) + (drawn.size() + 2) * sizeof(SurfacePoint<float>));
  std::vector<Segment<float>> pooled;
  std::size_t k = 0, mismatches = 0;
  list.unpack([&](std::uint32_t parent) -> const Segment<float>& { return pooled.at(parent); },
              [&](const RecordFields<float, Rgb<float>>& f, const SurfacePoint<float>& x, const SurfacePoint<float>& y) {
                const Segment<float> segment{x, y};
                const auto& r = drawn.at(k++);
                mismatches += !(same(segment.x, r.segment.x) && same(segment.y, r.segment.y) &&
                                f.first_direction == r.first_direction && f.last_direction == r.last_direction &&
                                f.chain == r.chain && f.geometry == r.geometry && f.sensor_weight == r.sensor_weight &&
                                f.density == r.density && f.pixel == r.pixel && f.parent == r.parent && f.flags == r.flags &&
                                f.pieces == r.pieces && f.next_event == r.next_event);
                pooled.push_back(segment);
              });
  CHECK(k == drawn.size());
  CHECK(mismatches == 0);
}
