#pragma once
/// \file thread_budget.h
/// How the live graph shares the machine's cores, decided in one place (README "Threads and
/// queues"). The camera-rate path (mask, tracking) runs at normal priority on its own threads;
/// the network and the Gaussian training run beside it at a lower priority (a higher nice value),
/// so on a loaded machine they take the time the camera-rate path leaves and never delay it.

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>
#include <thread>

namespace dypho {

/// Thread counts and priorities of the graph for a number of cores.
struct ThreadBudget {
  int cores = 1;            ///< cores the graph may use
  int opencv_threads = 1;   ///< OpenCV's pool (flow, ORB, the network's layers): half the cores, >= 1
  int mapping_threads = 1;  ///< rasterizer/optimiser pool including the mapping worker: every core (niced)
  int network_nice = 5;     ///< nice increment of the network worker thread
  int mapping_nice = 10;    ///< nice increment of the mapping worker and its pool
};

/// The priority a background thread lowers itself to.
struct ThreadPriority {
  int nice_increment = 0;  ///< added to the thread's nice value (capped at 19), >= 0
  /// Linux SCHED_IDLE: the thread runs only on CPU time no other thread wants. A niced thread
  /// still takes a share of a core it shares (nice +10: about 10 %); an idle-class one does not.
  /// Lowering a thread's own priority needs no privilege.
  bool idle_class = false;
};

/// The budget for `cores` cores (0 = every core of this machine).
inline ThreadBudget planThreadBudget(int cores) {
  ThreadBudget budget;
  const int available = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  budget.cores = cores > 0 ? cores : available;
  budget.opencv_threads = std::max(1, budget.cores / 2);
  budget.mapping_threads = budget.cores;
  return budget;
}

/// Names the calling thread (Linux: at most 15 characters, longer names are cut), so that
/// `top -H`, `ps -L` and profilers tell the graph's threads apart. Best effort.
inline void nameCurrentThread(const std::string& name) {
#ifdef __linux__
  ::pthread_setname_np(::pthread_self(), name.substr(0, 15).c_str());
#endif
}

/// Lowers the calling thread's priority (Linux: nice and scheduling class are per thread), which
/// needs no privilege. Returns an empty string on success, else the reason (the thread then keeps
/// what it could not change; callers log it once).
inline std::string lowerCurrentThreadPriority(const ThreadPriority& priority) {
#ifdef __linux__
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  if (priority.nice_increment > 0) {
    errno = 0;
    const int current = ::getpriority(PRIO_PROCESS, tid);
    if (current == -1 && errno != 0) return std::string("getpriority: ") + std::strerror(errno);
    if (::setpriority(PRIO_PROCESS, tid, std::min(19, current + priority.nice_increment)) != 0) {
      return std::string("setpriority: ") + std::strerror(errno);
    }
  }
  if (priority.idle_class) {
    sched_param param{};
    param.sched_priority = 0;
    if (::sched_setscheduler(static_cast<pid_t>(tid), SCHED_IDLE, &param) != 0) {
      return std::string("sched_setscheduler(SCHED_IDLE): ") + std::strerror(errno);
    }
  }
  return {};
#else
  if (priority.nice_increment <= 0 && !priority.idle_class) return {};
  return "thread priorities are only set on Linux";
#endif
}

/// True when the calling thread runs in the SCHED_IDLE class (for tests and diagnostics).
inline bool currentThreadIsIdleClass() {
#ifdef __linux__
  return ::sched_getscheduler(0) == SCHED_IDLE;
#else
  return false;
#endif
}

/// The nice value of the calling thread (for tests and diagnostics).
inline int currentThreadNice() {
#ifdef __linux__
  return ::getpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)));
#else
  return 0;
#endif
}

}  // namespace dypho
