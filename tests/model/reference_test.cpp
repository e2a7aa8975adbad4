// The dynamics against Pinocchio's values for the UR5 and the Panda (tests/data/*.points.csv,
// copied from ../shared/reference/dynamics): M, g, C dq, C^T dq and inverse dynamics at 40
// random states each, to 1e-9 relative to the norm of the reference matrix or vector.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "momentum/model/dynamics.hpp"
#include "momentum/model/profile.hpp"

namespace {

using momentum::model::Data;
using momentum::model::Model;
using Eigen::MatrixXd;
using Eigen::VectorXd;

struct Table {
  std::string comment;
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  int column(const std::string& name) const {
    for (std::size_t k = 0; k < header.size(); ++k) {
      if (header[k] == name) return static_cast<int>(k);
    }
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
};

Table read_table(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  Table table;
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
      EXPECT_EQ(row.size(), table.header.size());
      table.rows.push_back(row);
    }
  }
  return table;
}

VectorXd vector_from(const Table& table, const std::vector<double>& row, const std::string& prefix,
                     int n) {
  VectorXd v(n);
  for (int j = 0; j < n; ++j) v[j] = row[table.column(prefix + std::to_string(j + 1))];
  return v;
}

double relative(const MatrixXd& got, const MatrixXd& want) {
  return (got - want).norm() / std::max(want.norm(), 1e-300);
}

class Reference : public ::testing::TestWithParam<std::string> {};

TEST_P(Reference, MatchesPinocchio) {
  const std::string data = MOMENTUM_TEST_DATA;
  const std::string robot = GetParam();
  const Table table = read_table(data + "/" + robot + ".points.csv");
  ASSERT_EQ(table.rows.size(), 40u);
  // The header comment states the gravity Pinocchio used.
  ASSERT_NE(table.comment.find("gravity -9.81 z"), std::string::npos) << table.comment;

  const auto profile = momentum::model::load_profile(data + "/" + robot + ".json");
  ASSERT_DOUBLE_EQ(profile.gravity.z(), -9.81);
  const Model model = momentum::model::build_model(profile);
  const int n = model.nq;
  ASSERT_EQ(n, robot == "ur5" ? 6 : 7);
  for (int j = 0; j < n; ++j) {
    // The comment lists the joint names in chain order.
    EXPECT_NE(table.comment.find(model.joints[j].name), std::string::npos);
  }
  Data data_(model);
  MatrixXd M;
  VectorXd g, cqd, ctqd, tau, p, beta;
  for (const auto& row : table.rows) {
    const VectorXd q = vector_from(table, row, "q", n);
    const VectorXd dq = vector_from(table, row, "dq", n);
    const VectorXd ddq = vector_from(table, row, "ddq", n);
    MatrixXd M_ref(n, n);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < n; ++k) {
        M_ref(i, k) = row[table.column("m" + std::to_string(i + 1) + "_" + std::to_string(k + 1))];
      }
    }
    const VectorXd g_ref = vector_from(table, row, "g", n);
    const VectorXd cqd_ref = vector_from(table, row, "cqd", n);
    const VectorXd ctqd_ref = vector_from(table, row, "ctqd", n);
    const VectorXd tau_ref = vector_from(table, row, "tau_id", n);

    momentum::model::mass_matrix(model, data_, q, M);
    momentum::model::gravity_torque(model, data_, q, g);
    momentum::model::coriolis_times_velocity(model, data_, q, dq, cqd);
    momentum::model::coriolis_transpose_times_velocity(model, data_, q, dq, ctqd);
    momentum::model::inverse_dynamics(model, data_, q, dq, ddq, tau);
    momentum::model::momentum_and_beta(model, data_, q, dq, p, beta);

    EXPECT_LT(relative(M, M_ref), 1e-9) << "M\n" << M << "\nref\n" << M_ref;
    EXPECT_LT(relative(g, g_ref), 1e-9) << g.transpose() << "\nref " << g_ref.transpose();
    EXPECT_LT(relative(cqd, cqd_ref), 1e-9) << cqd.transpose() << "\nref " << cqd_ref.transpose();
    EXPECT_LT(relative(ctqd, ctqd_ref), 1e-9)
        << ctqd.transpose() << "\nref " << ctqd_ref.transpose();
    EXPECT_LT(relative(tau, tau_ref), 1e-9) << tau.transpose() << "\nref " << tau_ref.transpose();
    EXPECT_LT(relative(p, M_ref * dq), 1e-9);
    EXPECT_LT(relative(beta, g_ref - ctqd_ref), 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(Robots, Reference, ::testing::Values("ur5", "panda"));

}  // namespace
