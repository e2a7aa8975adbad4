// mo-model: print the chain a profile builds, or append the dynamics of each row of a stream
// (g, beta, p, optionally M and the inverse dynamics).
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <string>

#include "momentum/cli/tool.hpp"
#include "momentum/core/error.hpp"
#include "momentum/model/describe.hpp"
#include "momentum/model/inertial_corrections.hpp"
#include "momentum/model/log_check.hpp"
#include "momentum/model/model.hpp"
#include "momentum/model/model_stream.hpp"
#include "momentum/model/profile.hpp"

using namespace momentum;

namespace {

// With no input named, a terminal (or /dev/null) on stdin means "just show me the chain";
// a pipe or a redirected file is a stream.
bool stdin_is_a_stream() {
  struct stat st {};
  if (::fstat(STDIN_FILENO, &st) != 0) return false;
  return !S_ISCHR(st.st_mode);
}

}  // namespace

int main(int argc, char** argv) {
  cli::Tool tool("mo-model", "Show the chain a robot profile builds, and its dynamics along a stream.");
  tool.app().footer("\nExample:\n  mo-model -p arm.json\n\nMore: man mo-model");
  tool.add_stream_inputs("input stream with q<j> (dq<j>, ddq<j>); none: the chain, or stdin when it is a pipe or file");
  tool.add_stream_output();
  tool.add_profile();
  tool.add_payload();
  bool chain = false;
  std::string check;
  model::ModelStreamOptions options;
  auto& app = tool.app();
  app.add_flag("--chain", chain, "print the chain even when an input is given or stdin is a pipe");
  app.add_flag("--mass-matrix", options.mass_matrix, "append the mass matrix entries m<i>_<k>");
  app.add_option("--check", check, "check the profile against a collision-free log (gravity, torque constants, joint order, units); exit 1 on a finding")
      ->type_name("LOG");

  return tool.run(argc, argv, [&] {
    if (tool.inputs().size() > 1) throw cli::UsageError("one input stream at a time");
    model::Profile profile = model::load_profile(tool.profile());
    model::select_payload(profile, tool.payload());
    const model::Model robot = model::build_model(profile);
    tool.set_chain_joints(robot.joint_names());  // a bag's joints are matched to them by name
    if (!check.empty()) {
      if (!tool.inputs().empty() || chain || options.mass_matrix)
        throw cli::UsageError("--check takes the log as its argument, without inputs, --chain or --mass-matrix");
      auto in = tool.open_input(check);
      const model::LogCheckSummary summary = model::check_log(*in, robot);
      const std::string text = model::describe_log_check(summary);
      std::fwrite(text.data(), 1, text.size(), stdout);
      return summary.findings.empty() ? cli::kSuccess : cli::kFailure;
    }
    if (chain || (tool.inputs().empty() && !stdin_is_a_stream())) {
      std::string text = model::describe_chain(robot, profile);
      if (!model::read_inertial_corrections(profile).empty())
        text += model::describe_corrections(model::build_nominal_model(profile), robot);
      std::fwrite(text.data(), 1, text.size(), stdout);
      return cli::kSuccess;
    }
    auto in = tool.open_input(tool.inputs().empty() ? "-" : tool.inputs().front());
    model::ModelStream annotate(*in, robot, options);
    auto out = tool.open_output(*in);
    annotate.run(*out);
    out->close();
    return cli::kSuccess;
  });
}
