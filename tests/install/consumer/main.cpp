// Uses the installed library: writes a two-row stream and reads it back.
#include <cstdio>
#include <string>

#include <momentum/stream/reader.hpp>
#include <momentum/stream/writer.hpp>

int main() {
  std::string path = "consumer.csv";
  {
    auto out = momentum::stream::Writer::open(path);
    out->header({"t", "q1"});
    double rows[2][2] = {{0.0, 1.5}, {0.001, 6.0}};
    for (auto& row : rows) out->row(row);
    out->close();
  }
  auto in = momentum::stream::Reader::open(path);
  double sum = 0;
  int n = 0;
  while (const double* row = in->next()) sum += row[in->require("q1")], ++n;
  std::printf("rows=%d sum=%g\n", n, sum);
  return 0;
}
