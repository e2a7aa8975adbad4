#include "momentum/model/model_stream.hpp"

#include <algorithm>

#include "momentum/core/error.hpp"
#include "momentum/stream/columns.hpp"

namespace momentum::model {

namespace {

// Indices of prefix1..prefixn, or empty when prefix1 is absent; throws when only some are.
std::vector<std::size_t> joint_indices(const stream::Reader& in, const std::string& prefix,
                                       int n) {
  const auto& columns = in.columns();
  if (!in.find(prefix + "1")) return {};
  return stream::column_indices(columns, stream::joint_columns(prefix, static_cast<std::size_t>(n)),
                                in.name());
}

void append(std::vector<std::string>& columns, const std::vector<std::string>& more) {
  columns.insert(columns.end(), more.begin(), more.end());
}

}  // namespace

ModelStream::ModelStream(stream::Reader& in, const Model& model, ModelStreamOptions options)
    : in_(in), model_(model), options_(options) {
  const int n = model.nq;
  if (const std::string zero = stream::zero_based_joint_message(in.columns()); !zero.empty())
    throw Error(in.name() + ": " + zero);
  const std::size_t joints = stream::count_joint_columns(in.columns(), "q");
  if (joints != static_cast<std::size_t>(n)) {
    throw Error(in.name() + ": the stream has " + std::to_string(joints) +
                " joints (columns q1..q" + std::to_string(joints) + ") but the chain " +
                model.root + " -> " + model.tip + " has " + std::to_string(n));
  }
  q_ = joint_indices(in, "q", n);
  dq_ = joint_indices(in, "dq", n);
  ddq_ = joint_indices(in, "ddq", n);
  if (!ddq_.empty() && dq_.empty()) {
    throw Error(in.name() + ": columns ddq<j> need dq<j> too (missing column 'dq1')");
  }
  const auto count = static_cast<std::size_t>(n);
  columns_ = in.columns();
  append(columns_, stream::joint_columns("g", count));
  if (!dq_.empty()) {
    append(columns_, stream::joint_columns("beta", count));
    append(columns_, stream::joint_columns("p", count));
  }
  if (options_.mass_matrix) {
    for (int i = 1; i <= n; ++i) {
      for (int k = 1; k <= n; ++k) columns_.push_back("m" + std::to_string(i) + "_" + std::to_string(k));
    }
  }
  if (!ddq_.empty()) append(columns_, stream::joint_columns("tau_id", count));
  for (std::size_t c = in.columns().size(); c < columns_.size(); ++c) {
    if (in.find(columns_[c])) {
      throw Error(in.name() + ": column '" + columns_[c] + "' is already in the input");
    }
  }
}

std::uint64_t ModelStream::run(stream::Writer& out) {
  const int n = model_.nq;
  const std::size_t width_in = in_.columns().size();
  out.header(columns_);
  in_.on_comment([&out](std::string_view text) { out.comment(text); });
  if (out.interactive()) in_.before_read([&out] { out.flush(); });

  Data data(model_);
  Eigen::VectorXd q(n), dq = Eigen::VectorXd::Zero(n), ddq(n), g(n), beta(n), p(n), tau(n);
  Eigen::MatrixXd M(n, n);
  std::vector<double> row(columns_.size());
  std::uint64_t rows = 0;
  while (const double* values = in_.next()) {
    std::copy(values, values + width_in, row.begin());
    for (int j = 0; j < n; ++j) q[j] = values[q_[j]];
    std::size_t at = width_in;
    auto put = [&](const Eigen::VectorXd& v) {
      std::copy(v.data(), v.data() + n, row.begin() + static_cast<std::ptrdiff_t>(at));
      at += static_cast<std::size_t>(n);
    };
    gravity_torque(model_, data, q, g);
    put(g);
    if (!dq_.empty()) {
      for (int j = 0; j < n; ++j) dq[j] = values[dq_[j]];
      momentum_and_beta(model_, data, q, dq, p, beta);
      put(beta);
      put(p);
    }
    if (options_.mass_matrix) {
      mass_matrix(model_, data, q, M);
      for (int i = 0; i < n; ++i) {
        for (int k = 0; k < n; ++k) row[at++] = M(i, k);
      }
    }
    if (!ddq_.empty()) {
      for (int j = 0; j < n; ++j) ddq[j] = values[ddq_[j]];
      inverse_dynamics(model_, data, q, dq, ddq, tau);
      put(tau);
    }
    out.row(row.data());
    ++rows;
  }
  in_.on_comment(nullptr);
  in_.before_read(nullptr);
  return rows;
}

}  // namespace momentum::model
