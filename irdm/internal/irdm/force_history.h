#pragma once
// The force history of the model's inputs, shared by the runtimes that convolve it (direct and
// representative waveforms): a ring of `slots` samples per input DoF (slot = step % slots),
// and the list of inputs that carried force within the last `keep` steps, the only ones whose
// convolutions can be nonzero. Sized once; no allocation afterwards.
#include <algorithm>
#include <vector>

namespace irdm
{
  class ForceHistory
  {
  public:
    void
    reset(const unsigned n_inputs, const unsigned slots, const long long keep)
    {
      slots_ = slots;
      keep_  = keep;
      f_.assign(static_cast<size_t>(n_inputs) * slots, 0.0);
      last_nonzero_.assign(n_inputs, -1);
      is_active_.assign(n_inputs, 0);
      active_.clear();
      active_.reserve(n_inputs);
    }

    /// Start of step n: inputs idle for `keep` steps leave the list (on_retire(k) is called
    /// and their ring is zeroed), and this step's slot of the others is cleared (it held the
    /// force of step n - slots).
    template <class OnRetire>
    void
    begin_step(const long long n, OnRetire &&on_retire)
    {
      active_.erase(std::remove_if(active_.begin(), active_.end(),
                                   [&](const unsigned k) {
                                     if (n - last_nonzero_[k] < keep_)
                                       return false;
                                     is_active_[k] = 0;
                                     std::fill_n(row(k), slots_, 0.0);
                                     on_retire(k);
                                     return true;
                                   }),
                    active_.end());
      for (const unsigned k : active_)
        row(k)[n % slots_] = 0.0;
    }

    /// Adds force f (N) on input DoF k to the sample of step n.
    void
    push(const unsigned k, const long long n, const double f)
    {
      row(k)[n % slots_] += f;
      last_nonzero_[k] = n;
      if (!is_active_[k])
        {
          is_active_[k] = 1;
          active_.push_back(k); // capacity reserved: never reallocates
        }
    }

    const std::vector<unsigned> &
    active() const
    {
      return active_;
    }
    double *
    row(const unsigned k)
    {
      return &f_[static_cast<size_t>(k) * slots_];
    }
    const double *
    row(const unsigned k) const
    {
      return &f_[static_cast<size_t>(k) * slots_];
    }
    unsigned
    slots() const
    {
      return slots_;
    }

  private:
    unsigned               slots_ = 1;
    long long              keep_  = 1;
    std::vector<double>    f_;            // [input DoF][slot]
    std::vector<long long> last_nonzero_; // per input DoF, -1: never
    std::vector<char>      is_active_;
    std::vector<unsigned>  active_;
  };
} // namespace irdm
