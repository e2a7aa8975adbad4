#include "momentum/cli/progress_text.hpp"

#include <algorithm>
#include <cmath>

namespace momentum::cli {

std::string progress_text(double done, double elapsed) {
  if (!(done > 0)) done = 0;
  done = std::min(done, 1.0);
  const int percent = static_cast<int>(std::floor(done * 100.0));
  std::string text = std::to_string(percent) + "%";
  if (done >= 1.0 || done < 0.01 || !(elapsed >= 1.0)) return text;
  const double left = elapsed * (1.0 - done) / done;
  if (left < 60) {
    const long seconds = std::max(5L, 5 * static_cast<long>(std::ceil(left / 5.0)));
    return text + ", about " + std::to_string(seconds) + " s left";
  }
  if (left < 3600) return text + ", about " + std::to_string(std::lround(left / 60.0)) + " min left";
  const long tens = std::lround(left / 600.0);  // tens of minutes
  const long hours = tens / 6, minutes = (tens % 6) * 10;
  return text + ", about " + std::to_string(hours) + " h" + (minutes ? " " + std::to_string(minutes) + " min" : "") +
         " left";
}

}  // namespace momentum::cli
