#pragma once
// The seed's two asynchronous loops (seed 001 section 4.2): a force thread (contact solve and
// force history at the haptic rate) and a deformation thread (full surface update at a display
// rate). They share the state of the body through a triple buffer, without locks.
//
// Why a triple buffer: in the modal runtime the whole force history is carried by the modal
// state, so the deformation thread needs only the newest state, never a past one (a ring of
// past forces would serve the direct model's convolution, which re-reads T steps of history).
// Three slots let the producer always have a slot of its own to write (it never waits, and a
// publish is one atomic exchange: wait-free), the consumer always read a whole slot (no torn
// state, unlike a seqlock the reader never retries), and the newest published slot sit between
// them. Ownership of a slot passes only through the exchange on middle_ (acquire-release), so
// every write to a slot happens-before every read of it: no data race (checked under
// ThreadSanitizer by tests/test_two_loops.cc).
#include <array>
#include <atomic>

namespace irdm
{
  template <typename T>
  class TripleBuffer
  {
  public:
    /// Every slot starts as a copy of prototype: size it here, so that neither thread
    /// allocates later.
    explicit TripleBuffer(const T &prototype)
      : slots_{prototype, prototype, prototype}
    {}

    /// Producer only: the slot to fill next.
    T &
    back()
    {
      return slots_[back_];
    }
    /// Producer only: makes back() the newest state and takes a free slot to write next.
    void
    publish()
    {
      back_ = middle_.exchange(back_ | fresh, std::memory_order_acq_rel) & index;
    }

    /// Consumer only: takes the newest published state if one arrived since the last call.
    /// Returns false (front() unchanged) if none did.
    bool
    update()
    {
      if ((middle_.load(std::memory_order_relaxed) & fresh) == 0)
        return false;
      front_ = middle_.exchange(front_, std::memory_order_acq_rel) & index;
      return true;
    }
    /// Consumer only: the state taken by the last update().
    const T &
    front() const
    {
      return slots_[front_];
    }

  private:
    static constexpr unsigned index = 3u, fresh = 4u;
    static_assert(std::atomic<unsigned>::is_always_lock_free);
    std::array<T, 3> slots_;
    // Each index on its own cache line: the threads do not share a line they both write.
    alignas(64) unsigned back_ = 0;
    alignas(64) unsigned front_ = 1;
    alignas(64) std::atomic<unsigned> middle_{2};
  };
} // namespace irdm
