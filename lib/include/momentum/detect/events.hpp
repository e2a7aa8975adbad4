#pragma once
// Collision events as mo-detect writes them, and the reader every other tool uses for them
// (mo-eval, mo-plot, the nightly script through mo-detect's exit status). The format is text
// CSV, documented in mo-detect(1) under EVENT FORMAT:
//
//   t_onset_estimate,t_detect,link,joints,kind,event,t_end,ended_by,peak1,...,peakn
//   7.104,7.184,2,1;2,onset,1,,,8.31,9.12,0.52
//   7.104,7.184,3,1;2;3,end,1,7.9,release,12.1,15.03,8.2
//
// Lines starting with '#' are comments (provenance). Each event has exactly one onset row,
// written the moment it is detected, and one end row; with contact identification an
// `identified` row comes between them, written once the identification at detection is done
// (the onset row does not wait for it). Rows of different events never interleave (an event
// ends before the next one opens).

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "momentum/core/file.hpp"

namespace momentum::detect {

// onset: the row on which the event was declared, as the detector knows it (no fit);
// identified: the same event once identification at detection is done (identified link,
// contact point, force, class when decided); end: the event over, with its whole identification.
enum class EventKind { onset, end, identified };
// Why an event ended: every joint back in its band for the hold time (release); a new contact
// began while it was open (next: the row that opened the next event); end of input with the
// event still open; SIGINT/SIGTERM with the event still open; the clock stepped back with the
// event still open (the detector starts again as on a new log).
enum class EndReason { none, release, next, eof, signal, clock_step };

std::string_view kind_name(EventKind kind);
std::string_view end_reason_name(EndReason reason);

struct Event {
  std::uint64_t id = 0;  // 1-based number of the event in its stream
  EventKind kind = EventKind::onset;
  // Estimated start of the contact, s: the first row of the run in which the earliest fired
  // joint left its usual band before crossing its threshold. <= t_detect.
  double t_onset_estimate = 0;
  // Time of the row on which the event was declared (first joint fired), s.
  double t_detect = 0;
  // Isolated link: the most distal joint that fired (paper's signature eta = [1..1, 0..0]),
  // 1..n. On an onset row: joints fired up to detection; on an end row: over the whole event.
  // On identified and end rows of an identified event: the link identification chose.
  int link = 0;
  // Every joint that fired, ascending, 1-based. Written "1;2;3".
  std::vector<int> joints;
  // End rows only (NaN / none on onset rows): first row of the quiet run that closed the event
  // (release), or the last row read (eof, signal), s. Identified rows: NaN / none, as onset rows.
  double t_end = 0;
  EndReason ended_by = EndReason::none;
  // Per joint, the peak |signal| (Nm) since the joint left its band or since detection,
  // whichever is earlier, up to this row. Size n (joints of the stream).
  std::vector<double> peaks;
  // What contact identification and classification found (lib/src/contact; mo-detect with a
  // model and joint positions), up to this row. Written in the contact columns; NaN and empty
  // when unknown.
  struct Contact {
    std::string event_class;        // "contact", "collision", or "" (not classified)
    double rise = NAN;              // s, onset estimate to 90% of the residual's peak
    double width = NAN;             // s, time the residual stays above half its peak
    double force = NAN;             // |F| at the strongest row, N
    double force_sd = NAN;          // its standard deviation, N
    double fx = NAN, fy = NAN, fz = NAN;  // F at the strongest row, world frame, N
    double px = NAN, py = NAN, pz = NAN;  // contact point in the link's frame, m
    double point_sd = NAN;          // m, along the link
    double peak_force = NAN;        // largest |F|, N
    double peak_force_sd = NAN;     // its standard deviation, N (contact::Location::peak_force_sd)
    double impulse = NAN;           // integral of |F|, N s
    double fit = NAN;               // weighted residual sum of squares per degree of freedom
    std::string seen;               // "point" (force and point determined), "force", "partial"
    // What is known of the link (contact::Location::candidates): each candidate link with its
    // posterior probability, most probable first; the smallest set of them whose probability
    // reaches the stated confidence (ascending) and that probability; the probability that
    // the event is a collision (NaN: no class rule with a slope, or not yet decided).
    std::vector<std::pair<int, double>> link_probabilities;
    std::vector<int> link_set;
    double set_probability = NAN;
    double collision_probability = NAN;
  } contact;
};

// Header line of an event file for `joints` joints (no trailing newline); `contact`: with the
// contact columns class,rise,width,f,fx,fy,fz,f_sd,px,py,pz,p_sd,f_peak,impulse,fit,seen,
// links,link_set,p_set,p_collision,f_peak_sd after the peaks (links: `link:probability` pairs separated by
// ';', most probable first; link_set: links separated by ';').
std::string event_header(std::size_t joints, bool contact = false);
// One event as a CSV line (no trailing newline); NaN t_end on onset rows is written empty, as
// is every unknown contact field.
std::string format_event(const Event& event, bool contact = false);

// Writes event rows to a file or stdout, flushing after every row so a consumer sees an event
// the moment it is detected. Uses core::OutputFile; a closed reader (EPIPE) throws
// stream::BrokenPipe.
class EventWriter {
 public:
  // Opens `path` ("-" or "": stdout) and writes `comments` (each as '#' + text) and the header
  // for `joints` joints. Throws momentum::Error when the file cannot be created.
  // `contact`: with the contact columns.
  EventWriter(const std::string& path, std::size_t joints, const std::vector<std::string>& comments,
              bool contact = false);
  ~EventWriter();
  EventWriter(const EventWriter&) = delete;
  EventWriter& operator=(const EventWriter&) = delete;

  // Writes and flushes one row. Throws momentum::Error on a write failure, stream::BrokenPipe
  // when the reader went away.
  void write(const Event& event);
  std::uint64_t rows_written() const { return rows_; }

 private:
  core::OutputFile out_;
  std::size_t joints_ = 0;
  bool contact_ = false;
  std::uint64_t rows_ = 0;
};

struct EventReaderOptions {
  // Also read the event files of other detectors (mo-eval): only t_detect and link are
  // required. Without t_onset_estimate it reads NaN; without joints, no joints; without kind,
  // every row is an onset; without event, every event number is 0 (unknown). A kind other
  // than onset or end (any case) skips the row; an empty link reads 0 (unknown) and link 0 is
  // allowed. Off: mo-detect's format, all of its columns required.
  bool other_detectors = false;
  // A malformed row throws momentum::Error `file:line: message`. Off: it is reported through
  // momentum::warn_row (kind "bad event row", `file:line: message; row skipped`), counted by
  // the tool's rows policy, and skipped.
  bool strict = true;
};

// Reads an event file row by row. Columns are found by name, so files with extra columns (a
// later version) still read; peak<j> columns give the joint count. Fields may carry blanks
// around them and the double quotes a spreadsheet adds.
class EventReader {
 public:
  // Opens `path` ("-": stdin) and reads its header. Throws momentum::Error `file:line: message`
  // when the file cannot be opened, has no header, or the header lacks one of
  // t_onset_estimate, t_detect, link, joints, kind, event (t_detect, link with
  // options.other_detectors).
  static std::unique_ptr<EventReader> open(const std::string& path, EventReaderOptions options = {});
  ~EventReader();

  // The next row, or nullopt at end of file. A malformed row (wrong field count, bad number,
  // t_detect not finite, unknown kind, joint or link out of 1..n) throws momentum::Error naming
  // file and line: an event file is written by a program, so damage is not skipped silently
  // (unless options.strict is off).
  std::optional<Event> next();

  std::size_t joints() const { return joints_; }
  const std::vector<std::string>& comments() const { return comments_; }
  // `file:line` of the row last returned.
  std::string where() const;

 private:
  EventReader() = default;
  bool read_line(std::string& line);
  // The event on `line`; nullopt for a row of another kind (other_detectors). Throws
  // momentum::Error `file:line: message` when it is malformed.
  std::optional<Event> parse(const std::string& line) const;
  EventReaderOptions options_;
  std::FILE* file_ = nullptr;
  bool owns_ = false;
  std::string name_;
  std::uint64_t line_ = 0;
  std::size_t joints_ = 0;
  std::size_t width_ = 0;
  std::vector<std::string> comments_;
  // Column index of each field (or npos when absent: the optional ones, and with
  // other_detectors all but t_detect and link).
  std::size_t c_onset_ = 0, c_detect_ = 0, c_link_ = 0, c_joints_ = 0, c_kind_ = 0, c_id_ = 0;
  std::size_t c_end_ = 0, c_ended_by_ = 0;
  std::vector<std::size_t> c_peaks_;
  std::vector<std::size_t> c_contact_;  // the contact columns in header order (npos: absent)
  std::vector<std::size_t> c_links_;    // links, link_set, p_set, p_collision (npos: absent)
  std::size_t c_peak_force_sd_ = 0;     // f_peak_sd (npos: absent)
};

// Reads a whole event file and returns its end rows (one per event, with the final joints,
// link and peaks); events without an end row (a file cut short) are returned from their onset
// row, kind onset, with ended_by none and t_end NaN, and the link and contact fields of their
// identified row when there is one. Throws like EventReader. For plots and evaluation of
// finished runs; streaming consumers use EventReader.
std::vector<Event> read_events(const std::string& path);

}  // namespace momentum::detect
