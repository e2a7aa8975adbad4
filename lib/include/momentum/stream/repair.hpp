#pragma once
// Mends the timing faults of controller logs without inventing or reordering samples: drops
// exact duplicate rows and rows out of time order, keeping the longest strictly increasing run
// of time stamps, decided over a sliding window so that memory stays constant.
//
// A row written early (t = 1, 2, 3, 7, 4, 5, 6, 8) loses only the early row (7), not the three
// rows it overtook, because the window sees that keeping 4, 5, 6 keeps more rows.

#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <vector>

namespace momentum::stream {

class TimeOrderRepair {
 public:
  struct Options {
    // Rows looked at together; a fault spanning more rows than half of it is resolved by
    // dropping the later rows.
    std::size_t window = 256;
  };
  struct Summary {
    std::uint64_t kept = 0;
    std::uint64_t duplicates = 0;   // equal to the previous row in every column
    std::uint64_t out_of_order = 0; // time not after the last kept row's
  };
  // `emit` receives each kept row in input order; `dropped` each dropped row with its location
  // and reason ("duplicate row" or "out of time order").
  using Emit = std::function<void(const double* row)>;
  using Dropped = std::function<void(const std::string& where, const std::string& reason)>;

  // `width`: values per row; `time_column`: index of t.
  TimeOrderRepair(std::size_t width, std::size_t time_column, Emit emit, Dropped dropped);
  TimeOrderRepair(std::size_t width, std::size_t time_column, Emit emit, Dropped dropped, Options options);

  void push(const double* row, const std::string& where);
  // Decides and emits everything still held; call at end of input.
  void finish();
  const Summary& summary() const { return summary_; }

 private:
  struct Pending {
    std::vector<double> values;
    std::string where;
  };
  void decide(std::size_t count);

  std::size_t width_, time_;
  Emit emit_;
  Dropped dropped_;
  Options options_;
  Summary summary_;
  std::deque<Pending> pending_;
  std::vector<double> last_pushed_;
  bool have_last_pushed_ = false;
  bool have_emitted_ = false;
  double last_emitted_t_ = 0;
};

}  // namespace momentum::stream
