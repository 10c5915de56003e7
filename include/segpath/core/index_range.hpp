// [begin, end) of an unsigned integer type as a random-access range: what std::views::iota
// gives, for the compilers whose iota_view does not compile with libstdc++ 12 (clang 14, Debian
// 12's), so that the library's headers build with both GCC and clang.
#pragma once

#include <compare>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <iterator>

namespace segpath {

template <std::unsigned_integral I>
class IndexRange {
 public:
  class Iterator {
   public:
    using value_type = I;
    using difference_type = std::ptrdiff_t;
    using iterator_concept = std::random_access_iterator_tag;
    using iterator_category = std::input_iterator_tag;  // dereferences to a value, not a reference
    constexpr Iterator() noexcept = default;
    constexpr explicit Iterator(I i) noexcept : i_(i) {}
    [[nodiscard]] constexpr I operator*() const noexcept { return i_; }
    [[nodiscard]] constexpr I operator[](difference_type n) const noexcept { return I(i_ + I(n)); }
    constexpr Iterator& operator++() noexcept { return ++i_, *this; }
    constexpr Iterator operator++(int) noexcept { return Iterator(i_++); }
    constexpr Iterator& operator--() noexcept { return --i_, *this; }
    constexpr Iterator operator--(int) noexcept { return Iterator(i_--); }
    constexpr Iterator& operator+=(difference_type n) noexcept { return i_ = I(i_ + I(n)), *this; }
    constexpr Iterator& operator-=(difference_type n) noexcept { return i_ = I(i_ - I(n)), *this; }
    [[nodiscard]] friend constexpr Iterator operator+(Iterator a, difference_type n) noexcept { return a += n; }
    [[nodiscard]] friend constexpr Iterator operator+(difference_type n, Iterator a) noexcept { return a += n; }
    [[nodiscard]] friend constexpr Iterator operator-(Iterator a, difference_type n) noexcept { return a -= n; }
    [[nodiscard]] friend constexpr difference_type operator-(const Iterator& a, const Iterator& b) noexcept {
      return difference_type(a.i_) - difference_type(b.i_);
    }
    friend constexpr bool operator==(const Iterator&, const Iterator&) noexcept = default;
    friend constexpr auto operator<=>(const Iterator&, const Iterator&) noexcept = default;

   private:
    I i_ = 0;
  };

  constexpr IndexRange() noexcept = default;
  constexpr IndexRange(I begin, I end) noexcept : begin_(begin), end_(end < begin ? begin : end) {}
  [[nodiscard]] constexpr Iterator begin() const noexcept { return Iterator(begin_); }
  [[nodiscard]] constexpr Iterator end() const noexcept { return Iterator(end_); }
  [[nodiscard]] constexpr std::size_t size() const noexcept { return std::size_t(end_ - begin_); }
  [[nodiscard]] constexpr bool empty() const noexcept { return begin_ == end_; }
  [[nodiscard]] constexpr I operator[](std::size_t n) const noexcept { return I(begin_ + I(n)); }

 private:
  I begin_ = 0, end_ = 0;
};

static_assert(std::ranges::random_access_range<IndexRange<std::uint32_t>> &&
              std::ranges::sized_range<IndexRange<std::uint32_t>>);

}  // namespace segpath
