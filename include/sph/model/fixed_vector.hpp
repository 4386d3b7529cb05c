// A vector of at most N elements held in the object itself: what the model's calibration is made
// of, so that a calibration can be held where there is no heap (firmware), with the interface of
// std::vector that the fit code uses. Header-only, no dependencies but the standard library's
// headers; never allocates and never throws.
//
// Adding an element beyond N is a programming error (the bounds come from the effect catalogue and
// the readers check them): it stops the program at once (__builtin_trap), as an out-of-memory error
// does where there are no exceptions, instead of writing past the storage.
#ifndef SPH_MODEL_FIXED_VECTOR_HPP_
#define SPH_MODEL_FIXED_VECTOR_HPP_

#include <cstddef>
#include <initializer_list>
#include <iterator>
#include <type_traits>
#include <utility>
#include <vector>

namespace sph {

template <typename T, std::size_t N>
class FixedVector {
 public:
  using value_type = T;
  using size_type = std::size_t;
  using difference_type = std::ptrdiff_t;
  using reference = T&;
  using const_reference = const T&;
  using pointer = T*;
  using const_pointer = const T*;
  using iterator = T*;
  using const_iterator = const T*;

  FixedVector() = default;
  FixedVector(std::initializer_list<T> items) { assign(items.begin(), items.end()); }
  /// From any range whose elements convert to T (a std::vector, another FixedVector).
  template <typename Range, typename = decltype(std::begin(std::declval<const Range&>())),
            typename = std::enable_if_t<!std::is_same_v<std::decay_t<Range>, FixedVector>>>
  FixedVector(const Range& items) {  // NOLINT: implicit, as std::vector's copy is
    assign(std::begin(items), std::end(items));
  }
  /// As a std::vector (for code that keeps one).
  operator std::vector<T>() const { return std::vector<T>(begin(), end()); }  // NOLINT: implicit

  static constexpr size_type capacity() { return N; }
  static constexpr size_type max_size() { return N; }
  size_type size() const { return size_; }
  bool empty() const { return size_ == 0; }

  T* data() { return items_; }
  const T* data() const { return items_; }
  iterator begin() { return items_; }
  iterator end() { return items_ + size_; }
  const_iterator begin() const { return items_; }
  const_iterator end() const { return items_ + size_; }
  const_iterator cbegin() const { return items_; }
  const_iterator cend() const { return items_ + size_; }

  T& operator[](size_type i) { return items_[i]; }
  const T& operator[](size_type i) const { return items_[i]; }
  T& front() { return items_[0]; }
  const T& front() const { return items_[0]; }
  T& back() { return items_[size_ - 1]; }
  const T& back() const { return items_[size_ - 1]; }

  void push_back(const T& item) {
    Grow(1);
    items_[size_ - 1] = item;
  }
  void push_back(T&& item) {
    Grow(1);
    items_[size_ - 1] = std::move(item);
  }
  template <typename... Args>
  T& emplace_back(Args&&... args) {
    Grow(1);
    items_[size_ - 1] = T{std::forward<Args>(args)...};
    return items_[size_ - 1];
  }
  void pop_back() { items_[--size_] = T{}; }
  void clear() { resize(0); }
  void resize(size_type n) { resize(n, T{}); }
  void resize(size_type n, const T& item) {
    if (n > N) Overflow();
    for (size_type i = n; i < size_; ++i) items_[i] = T{};
    for (size_type i = size_; i < n; ++i) items_[i] = item;
    size_ = n;
  }
  void assign(size_type n, const T& item) {
    clear();
    resize(n, item);
  }
  template <typename It, typename = typename std::iterator_traits<It>::iterator_category>
  void assign(It first, It last) {
    clear();
    for (; first != last; ++first) push_back(T(*first));
  }
  void assign(std::initializer_list<T> items) { assign(items.begin(), items.end()); }

  iterator insert(const_iterator pos, const T& item) {
    const size_type at = Index(pos);
    Grow(1);
    for (size_type i = size_ - 1; i > at; --i) items_[i] = std::move(items_[i - 1]);
    items_[at] = item;
    return items_ + at;
  }
  template <typename It, typename = typename std::iterator_traits<It>::iterator_category>
  iterator insert(const_iterator pos, It first, It last) {
    size_type at = Index(pos);
    const size_type start = at;
    for (; first != last; ++first) insert(items_ + at++, T(*first));
    return items_ + start;
  }
  iterator erase(const_iterator pos) { return erase(pos, pos + 1); }
  iterator erase(const_iterator first, const_iterator last) {
    const size_type from = Index(first), to = Index(last);
    if (from == to) return items_ + from;
    size_type out = from;
    for (size_type i = to; i < size_; ++i) items_[out++] = std::move(items_[i]);
    for (size_type i = out; i < size_; ++i) items_[i] = T{};
    size_ = out;
    return items_ + from;
  }

  friend bool operator==(const FixedVector& a, const FixedVector& b) {
    if (a.size_ != b.size_) return false;
    for (size_type i = 0; i < a.size_; ++i) {
      if (!(a.items_[i] == b.items_[i])) return false;
    }
    return true;
  }
  friend bool operator!=(const FixedVector& a, const FixedVector& b) { return !(a == b); }

 private:
  size_type Index(const_iterator p) const { return static_cast<size_type>(p - items_); }
  void Grow(size_type n) {
    if (n > N - size_) Overflow();
    size_ += n;
  }
  [[noreturn]] static void Overflow() { __builtin_trap(); }

  size_type size_ = 0;  // first: beside the first elements, in the cache line a loop reads first
  T items_[N]{};
};

}  // namespace sph

#endif  // SPH_MODEL_FIXED_VECTOR_HPP_
