// Scoring a collision detector against ground truth: which contacts it found, how late, whether
// it named the right link, and how often it cried wolf.
//
// Matching: contacts and events are taken in time order. An event whose t_detect lies in
// [t_onset, t_onset + window] of a contact not yet detected detects it (the earliest such
// contact; delay = t_detect - t_onset). Isolation is right when the event's final link (its
// end row's: the fault signature over the whole event) is the contact's; isolation at
// detection compares the link of the onset row, all a live reaction knows at that instant.
// An event that detects nothing but falls within a contact's span [t_onset, t_end + window]
// is not a false alarm: it is a repeat (the contact was already detected) or late (it was not,
// and its window had passed). Every other event is a false alarm. Collision-free time is the
// run's duration minus the union of the contacts' spans.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <nlohmann/json.hpp>

#include "momentum/contact/classify.hpp"
#include "momentum/eval/truth.hpp"

namespace momentum::eval {

// One detection, from a detector's event file.
struct Detection {
  double t_detect = 0;           // s
  double t_onset_estimate = NAN; // s, NaN when the file has no such column
  int link = 0;                  // isolated link at detection (onset row), 1..n; 0: unknown
  int final_link = 0;            // isolated link over the whole event (end row), else = link
  std::string where;             // file:line, for messages
  // Identification and classification (mo-detect's contact columns), from the end row when
  // there is one; NaN / empty when the file has none.
  std::string event_class;       // "contact", "collision", ""
  double peak_force = NAN;       // N
  Eigen::Vector3d point{NAN, NAN, NAN};  // in the final link's frame, m
  double peak_force_sd = NAN;    // N, the stated sd of peak_force
  double point_sd = NAN;         // m, the stated 68% radius of the point
  double width = NAN;            // s, the residual's pulse width
  double rise = NAN;             // s, its rise time
  std::vector<double> peaks;     // per joint, Nm
  // What identification states of itself (mo-detect's links, link_set, p_set, p_collision):
  // each candidate link's probability, the link set at its confidence and that confidence's
  // probability, the probability of a collision; empty / NaN when not stated.
  std::vector<std::pair<int, double>> link_probabilities;
  std::vector<int> link_set;
  double set_probability = NAN;
  double collision_probability = NAN;
};

// Reads an event file (a path, or "-" for stdin) with detect::EventReader, open to other
// detectors' files: a header naming at least t_detect and link; optional t_onset_estimate and
// the rest of mo-detect's columns. Each onset row is a detection (without a kind column: every
// row; rows of other kinds are skipped), and the end row of the same "event" number, when
// present, gives its final link and identification; without an event column every row is its
// own event, with one, only the first onset row of each number counts. A malformed row is
// reported through momentum::warn_row (`file:line: message; row skipped`) and skipped
// (strict: momentum::Error `file:line: message`). Throws momentum::Error when the file cannot
// be read or the header lacks t_detect or link.
std::vector<Detection> read_detections(const std::string& path, bool strict = false);

struct ScoreOptions {
  double window = 0.5;               // s after onset within which a detection counts, > 0
  std::optional<double> duration;    // s; overrides the truth file's
  // Nm, >= 0. A contact whose largest peak joint torque (tau_peak<j>) stays below this could not
  // move any residual above the noise: it is still scored (a miss is a miss), and also counted
  // apart as unfelt, so that a detector is judged on the contacts a joint could feel. 0: off.
  // Contacts without tau_peak columns are always felt.
  double min_torque = 0;
  bool IsValid(std::string* why) const;
};

// Outcome of one contact.
struct ContactOutcome {
  TruthContact contact;
  bool detected = false;
  double delay = NAN;               // s
  int reported_link = 0;            // final link of the detecting event
  int link_at_detection = 0;        // link of its onset row
  double onset_error = NAN;         // t_onset_estimate - t_onset, s (when given)
  int detection = -1;               // index of the detecting event in score()'s detections
  std::string event_class;          // the detecting event's class ("" when not classified)
  double force_error = NAN;         // |estimated - true peak force|, N (when both are known)
  double point_error = NAN;         // |estimated - true point|, m (when both are known, link right)
  double peak_force_sd = NAN, point_sd = NAN;  // the detecting event's stated uncertainties
  std::vector<std::pair<int, double>> link_probabilities;  // the detecting event's (Detection)
  std::vector<int> link_set;
  double set_probability = NAN;
  double collision_probability = NAN;
};

// How well stated probabilities hold: statements "this is true with probability p" and whether
// each was. Reliability: the statements binned by p (bins of equal width over [0, 1], the last
// closed), each bin's mean stated p against the share that came true.
struct ReliabilityBin {
  double low = 0, high = 0;     // the bin's range of p
  int statements = 0, came_true = 0;
  double mean_stated = NAN;     // mean p in the bin
};
struct Calibration {
  int statements = 0, came_true = 0;
  double brier = NAN;     // mean (p - outcome)^2, outcome 1 or 0 (0: perfect, 0.25: p = 0.5 always)
  double log_loss = NAN;  // mean -ln(p of what happened), p kept within [1e-6, 1 - 1e-6]
  std::vector<ReliabilityBin> bins;
};
// The calibration of `statements` (probability, came true), probabilities in [0, 1], in `bins`
// (>= 1) bins. Statements with a probability that is not finite are left out.
Calibration calibration(const std::vector<std::pair<double, bool>>& statements, int bins = 5);

// The link sets of the detected contacts that state one (Detection::link_set).
struct LinkSetStats {
  int with_set = 0;           // detected contacts with a link set
  int truth_in_set = 0;       // ... whose true link is in it
  int truth_in_pair = 0;      // ... in a set of at most two links
  double mean_size = NAN;     // links per set
  double mean_stated = NAN;   // mean set probability (p_set): what truth_in_set / with_set should be
  // Every candidate link's probability against whether it is the true link (an event whose
  // true link is no candidate states probability 0 for it: one statement more, false, that
  // came true).
  Calibration links;
  // The probability of a collision against the truth's clamp, over the detected contacts
  // that state one.
  Calibration classes;
};

struct DelayStats {
  int count = 0;
  double min = NAN, median = NAN, p95 = NAN, max = NAN, mean = NAN;  // s
};

// Medians of identification's errors over the detected contacts where they are known.
struct IdentificationStats {
  int classified = 0, class_right = 0;  // detected contacts with a class, and with the true one
  DelayStats force_error;               // N
  DelayStats force_error_percent;       // % of the true peak force
  DelayStats point_error;               // m
  // Coverage of the stated uncertainties: the contacts whose force error is within the event's
  // stated f_peak_sd (one standard deviation: about 68% should be), and whose point error is within
  // its p_sd (a 68% radius), of those with both known.
  int force_with_sd = 0, force_covered = 0;
  int point_with_sd = 0, point_covered = 0;
};

struct LinkScore {
  int link = 0;
  int contacts = 0, detected = 0, isolated = 0;
  DelayStats delay;
  IdentificationStats identification;
};

struct Score {
  double window = 0;
  std::optional<double> duration;           // s, when known
  int contacts = 0, detected = 0, missed = 0;
  double min_torque = 0;                    // Nm, the options' (0: no contact is set apart)
  int felt = 0, felt_detected = 0;          // contacts at or above min_torque, and of them detected
  int events = 0, false_alarms = 0, repeats = 0, late = 0;
  std::optional<double> collision_free;     // s, when the duration is known
  std::optional<double> false_alarms_per_hour;
  DelayStats delay;
  int isolated = 0;                          // detected contacts with the right final link
  int isolated_at_detection = 0;             // ... with the right link on the onset row
  DelayStats onset_error;                    // |t_onset_estimate - t_onset|, when given
  IdentificationStats identification;        // class, force and point against the truth
  LinkSetStats link_sets;                    // the stated link sets and probabilities against the truth
  std::vector<LinkScore> by_link;            // ascending link
  std::vector<ContactOutcome> outcomes;      // per contact, onset order
  std::vector<double> false_alarm_times;     // t_detect of each false alarm
};

// Matches `detections` to `truth` (see the top of this file). Throws momentum::Error for invalid
// options.
Score score(const Truth& truth, const std::vector<Detection>& detections, const ScoreOptions& options);

// The detected contacts as labelled examples for learning the contact/collision rule
// (contact/classify.hpp): each detecting event's pulse width, rise and peaks, and whether the
// contact was a collision (an obstacle met: the truth's clamp). Events without a width (no
// identification) are left out.
std::vector<contact::ClassExample> class_examples(const Truth& truth, const std::vector<Detection>& detections,
                                                  const ScoreOptions& options);

// Percentiles of a sample by linear interpolation between order statistics (numpy's default);
// p in [0, 100]. NaN for an empty sample.
double percentile(std::vector<double> values, double p);

// The score as a table for a person (lines end with '\n'); `list` adds one line per contact
// and per false alarm.
std::string format_table(const Score& score, bool list);

// The score for scripts (times in seconds; null for unknown values).
nlohmann::json to_json(const Score& score);

}  // namespace momentum::eval
