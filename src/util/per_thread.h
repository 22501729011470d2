// One object per OpenMP thread, each built by the thread that uses it, on first use.
//
// Why not a std::vector<T> of them built up front: neighbouring objects (and the small buffers
// they allocate from the building thread's heap) then share cache lines, and two threads writing
// their own counters or scratch vectors on one line slow each other down (false sharing). It
// cost the occluded-pair fill a third of its time on two threads, varying with unrelated
// allocation sizes. Built by its own thread, an object and everything it allocates come from that
// thread's malloc arena (glibc gives each thread its own).
#pragma once

#include <omp.h>

#include <functional>
#include <memory>
#include <vector>

namespace photometria {

template <class T>
class PerThread {
 public:
  // `make` builds one T; it is called once per thread that asks, from that thread.
  explicit PerThread(std::function<std::unique_ptr<T>()> make)
      : make_(std::move(make)), objects_(size_t(omp_get_max_threads())) {}

  // The calling thread's object (omp_get_thread_num() within a parallel region, else thread 0's).
  T& local() {
    std::unique_ptr<T>& p = objects_[size_t(omp_get_thread_num())];
    if (!p) p = make_();
    return *p;
  }

 private:
  std::function<std::unique_ptr<T>()> make_;
  std::vector<std::unique_ptr<T>> objects_;
};

}  // namespace photometria
