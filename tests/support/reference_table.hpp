#pragma once
// Reads the reference tables copied from ../shared/reference (tests/data/*.points.csv): '#'
// comment lines, a header of column names, then rows of numbers. Failures are reported to
// GoogleTest (the file missing, a ragged row, a column asked for that is not there).
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace momentum::testing {

struct ReferenceTable {
  std::string comment;  // the '#' lines, joined
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;

  int column(const std::string& name) const {
    for (std::size_t k = 0; k < header.size(); ++k)
      if (header[k] == name) return static_cast<int>(k);
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
  // Columns prefix1..prefixN of one row.
  Eigen::VectorXd vector(std::size_t row, const std::string& prefix, int n) const {
    Eigen::VectorXd v(n);
    for (int j = 0; j < n; ++j) v[j] = rows[row][static_cast<std::size_t>(column(prefix + std::to_string(j + 1)))];
    return v;
  }
};

inline ReferenceTable read_reference_table(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  ReferenceTable table;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '#') {
      table.comment += line;
      continue;
    }
    std::stringstream cells(line);
    std::string cell;
    if (table.header.empty()) {
      while (std::getline(cells, cell, ',')) table.header.push_back(cell);
    } else {
      std::vector<double> row;
      while (std::getline(cells, cell, ',')) row.push_back(std::stod(cell));
      EXPECT_EQ(row.size(), table.header.size()) << path;
      table.rows.push_back(row);
    }
  }
  return table;
}

}  // namespace momentum::testing
