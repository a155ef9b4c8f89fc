// skidimm plot: the paper's figure, drawn by gnuplot.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>

#include "commands.h"
#include "skidimm/config/bank.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/io/output_file.h"
#include "skidimm/printable.h"
#include "skidimm/time_origin.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;

namespace {

std::string find_gnuplot() {
  const char* path = std::getenv("PATH");
  std::stringstream in(path != nullptr ? path : "");
  std::string dir;
  while (std::getline(in, dir, ':')) {
    const fs::path candidate = fs::path(dir.empty() ? "." : dir) / "gnuplot";
    if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return "";
}

// A gnuplot string. Text from the files (mode names from the header) is
// made printable first: a newline in a mode name would otherwise end the
// string and start a gnuplot command of the file's choosing.
std::string gnuplot_string(const std::string& s) {
  std::string out = "'";
  for (char c : printable(s)) {  // printable() keeps line breaks and tabs, for messages
    if (c == '\'') {
      out += "''";
    } else if (c == '\n') {
      out += "\\x0A";
    } else if (c == '\t') {
      out += "\\x09";
    } else {
      out += c;
    }
  }
  return out + "'";
}

// A file gnuplot reads or writes: its name must reach gnuplot unchanged.
std::string file_name(const fs::path& path) {
  const std::string name = path.string();
  if (printable(name) != name || name.find_first_of("\t\n") != std::string::npos) {
    throw Error("'" + name + "': gnuplot cannot be given a file name with control characters; rename the file");
  }
  return gnuplot_string(name);
}

// Files plot writes for gnuplot, removed when plot ends.
class TemporaryFiles {
 public:
  TemporaryFiles() = default;
  TemporaryFiles(const TemporaryFiles&) = delete;
  TemporaryFiles& operator=(const TemporaryFiles&) = delete;
  ~TemporaryFiles() {
    if (kept_) return;
    std::error_code ec;
    for (const fs::path& p : paths_) fs::remove(p, ec);
  }
  void push_back(const fs::path& path) { paths_.push_back(path); }
  void keep() { kept_ = true; }

 private:
  std::vector<fs::path> paths_;
  bool kept_ = false;
};

// Runs `gnuplot script` without a shell (no quoting of the names to get
// wrong), its standard error into `errors`. Returns its exit status, or -1
// when it could not be started or did not exit normally.
int run_gnuplot(const std::string& gnuplot, const fs::path& script, const fs::path& errors) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, errors.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::string program = gnuplot;
  std::string argument = script.string();
  char* argv[] = {program.data(), argument.data(), nullptr};
  // skidimm ignores SIGPIPE (a closed output is an error it reports); a
  // child would inherit that, so gnuplot gets the default back.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t default_signals;
  sigemptyset(&default_signals);
  sigaddset(&default_signals, SIGPIPE);
  posix_spawnattr_setsigdefault(&attributes, &default_signals);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGDEF);
  pid_t pid = 0;
  const int started = posix_spawn(&pid, gnuplot.c_str(), &actions, &attributes, argv, environ);
  posix_spawnattr_destroy(&attributes);
  posix_spawn_file_actions_destroy(&actions);
  if (started != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int column_of(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i) + 1;  // gnuplot counts from 1
  }
  return 0;
}

}  // namespace

int plot(const PlotOptions& options) {
  return report_errors("skidimm plot", [&] {
    const std::string extension = options.output.extension().string();
    std::string terminal;
    if (extension == ".png") {
      terminal = "pngcairo";
    } else if (extension == ".svg") {
      terminal = "svg";
    } else {
      throw UsageError("--output " + options.output.string() + ": the figure must end in .png or .svg");
    }
    const std::string gnuplot = find_gnuplot();
    if (gnuplot.empty()) {
      throw Error(
          "gnuplot is not installed or not on PATH; install it with `apt-get install gnuplot-nox` "
          "(scripts/setup.sh does)");
    }

    refuse_clashing_files({{"--output", options.output}},
                          {{"--estimates", options.estimates}, {"--bank", options.bank}});
    if (!options.log.empty()) refuse_output_over_logs(options.output, "--output", {join_log_arguments(options.log)});
    TemporaryFiles temporary;  // removed however plot ends, unless kept
    CsvReader reader(options.estimates);
    const std::vector<std::string> header = reader.header();
    // gnuplot reads the estimates again: standard input or a pipe is copied
    // to a file beside the figure as it is read (removed at the end).
    fs::path estimates_file = options.estimates;
    std::optional<CsvWriter> estimates_copy;
    if (!is_rereadable(options.estimates)) {
      estimates_file = options.output.string() + ".estimates.csv";
      estimates_copy.emplace(estimates_file, header);
      temporary.push_back(estimates_copy->partial_path());  // kept by CsvWriter if plot fails midway
    }
    std::vector<std::pair<int, std::string>> modes;
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (header[i].rfind("mu_", 0) == 0) modes.emplace_back(static_cast<int>(i) + 1, header[i].substr(3));
    }
    if (modes.empty() || column_of(header, "t") != 1) {
      throw LogError(options.estimates.string(), 1, "not a `skidimm run` output: expected t and mu_<mode> columns");
    }
    // A class (`classes:` of the bank) is drawn in its first mode's colour:
    // its truth bands and its row of the decision track. Without the bank a
    // class has no colour of its own, so none that reads as a mode's.
    std::map<std::string, int> first_mode_of_class;
    if (!options.bank.empty()) {
      // The bank reads the log for the figure's panels: another bank's would
      // draw them from another log's columns, or from none, without a word.
      std::vector<std::string> names;
      for (const auto& mode : modes) names.push_back(mode.second);
      const BankConfig config = load_bank_config(options.bank);
      const std::string problem = config.estimates_modes_problem(names);
      if (!problem.empty()) throw LogError(options.estimates.string(), 1, problem);
      for (const ClassConfig& c : config.classes) {
        if (!c.modes.empty()) first_mode_of_class[c.name] = c.modes.front() + 1;  // gnuplot's line types count from 1
      }
    }
    // State columns: those followed by var_<state>.
    std::vector<std::string> states;
    for (const std::string& h : header) {
      if (h.rfind("var_", 0) == 0) states.push_back(h.substr(4));
    }
    // Truth intervals from truth_mode.
    const int truth = column_of(header, "truth_mode");
    struct Band {
      double start, end;
      std::string mode;
    };
    std::vector<Band> bands;
    // The decision track (`skidimm run`'s decision column), as intervals.
    const int decision = column_of(header, "decision");
    std::vector<Band> decisions;
    std::vector<std::string> fields;
    double first_t = 0.0, last_t = 0.0;
    long rows = 0;
    while (reader.next(&fields)) {
      double t = 0.0;
      if (!parse_finite_number(fields[0], &t)) {
        throw LogError(reader.path().string(), reader.line(),  // "standard input" for -
                       "column 1 ('t'): expected the time, a finite number, got '" + fields[0].substr(0, 80) + "'");
      }
      // As `run` writes them; gnuplot would draw anything else wrongly or fail with its own words.
      if (rows++ > 0 && !(t > last_t)) {
        throw LogError(reader.path().string(), reader.line(),
                       "column 1 ('t'): time must increase, but " + fields[0].substr(0, 80) + " follows " +
                           CsvWriter::format(last_t));
      }
      // gnuplot draws a probability that is not one (nan, text, outside [0, 1])
      // as a gap or off the axis, without a word.
      for (const auto& [column, mode] : modes) {
        const std::string& cell = fields[static_cast<std::size_t>(column - 1)];
        double mu = 0.0;
        if (!parse_finite_number(cell, &mu) || mu < 0.0 || mu > 1.0 + 1e-9) {
          throw LogError(reader.path().string(), reader.line(),
                         "column " + std::to_string(column) + " ('mu_" + mode +
                             "'): expected a probability, a number from 0 to 1, got '" + cell.substr(0, 80) + "'");
        }
      }
      if (estimates_copy) estimates_copy->write_row(fields);
      if (rows == 1) first_t = t;
      last_t = t;
      if (decision > 0) {
        const std::string& decided = fields[static_cast<std::size_t>(decision - 1)];
        if (decisions.empty() || decisions.back().mode != decided) {
          if (!decisions.empty()) decisions.back().end = t;
          decisions.push_back({t, t, decided});
        }
        decisions.back().end = t;
      }
      if (truth == 0) continue;
      const std::string& mode = fields[static_cast<std::size_t>(truth - 1)];
      if (bands.empty() || bands.back().mode != mode) {
        if (!bands.empty()) bands.back().end = t;
        bands.push_back({t, t, mode});
      }
      bands.back().end = t;
    }

    if (rows < 2) {
      throw LogError(reader.path().string(), reader.line(),
                     rows == 0 ? "no rows to plot: the estimates have a header only"
                               : "one row: a figure over time needs two time stamps or more");
    }
    if (estimates_copy) {
      estimates_copy->commit();
      temporary.push_back(estimates_file);
    }

    // The log's measurements and true states: read with the bank exactly as
    // `run` read them (any log form) into a data file for gnuplot, or, without
    // a bank, straight from a single CSV whose columns are named like the states.
    fs::path log_file;
    std::vector<std::string> log_header;
    const fs::path log_data = options.output.string() + ".log.csv";
    temporary.push_back(log_data.string() + ".partial");
    if (!options.log.empty() && options.states) {  // the log is drawn in the states' panels alone
      fs::path given_log;                          // without --bank: the one file, as --log named it
      if (!options.bank.empty()) {
        const BankConfig config = load_bank_config(options.bank);
        const LogSpec log = join_log_arguments(options.log);
        LogReader reader(config, log.files, sampling_of(config, options.rate));
        std::vector<std::string> header{"t"};
        for (const std::string& m : config.measurement.names) header.push_back(m);
        // True states only where the log has them: a column of NaN would still get a 'true' line in the legend.
        const bool with_true_states = reader.has_true_states();
        if (with_true_states) {
          for (const std::string& s : config.state_names) header.push_back("true_" + s);
        }
        CsvWriter writer(log_data, header);
        std::vector<std::string> cells(header.size());
        LogSample sample;
        while (reader.next(&sample)) {
          std::size_t c = 0;
          cells[c++] = CsvWriter::format(sample.t);
          for (Eigen::Index i = 0; i < sample.z.size(); ++i) cells[c++] = CsvWriter::format(sample.z[i]);
          for (Eigen::Index i = 0; with_true_states && i < sample.true_state.size(); ++i) {
            cells[c++] = CsvWriter::format(sample.true_state[i]);
          }
          writer.write_row(cells);
        }
        writer.commit();
        temporary.push_back(log_data);
        log_file = log_data;
      } else {
        if (options.log.size() != 1 || parse_log_spec(options.log[0]).files.size() != 1) {
          throw Error("--log with several files needs --bank to read them");
        }
        given_log = parse_log_spec(options.log[0]).files[0].path;
        log_file = given_log;
        if (!is_rereadable(log_file)) {  // read here for its header, then by gnuplot: copy it
          CsvReader log_reader(log_file);
          CsvWriter copy(log_data, log_reader.header());
          std::vector<std::string> cells;
          while (log_reader.next(&cells)) copy.write_row(cells);
          copy.commit();
          temporary.push_back(log_data);
          log_file = log_data;
        }
      }
      log_header = CsvReader(log_file).header();
      if (options.bank.empty()) {
        // Read without a bank, the log is drawn by its columns' names: a log
        // named otherwise would add nothing to the figure, without a word.
        bool drawn = false;
        for (const std::string& s : states) {
          drawn = drawn || column_of(log_header, s) > 0 || column_of(log_header, "true_" + s) > 0;
        }
        if (column_of(log_header, "t") == 0 || !drawn) {
          std::string columns;
          for (const std::string& h : log_header) columns += (columns.empty() ? "" : ", ") + h;
          throw Error(given_log.string() +
                      ": nothing of this log can be drawn: without --bank, --states draws its columns named like the "
                      "states or 'true_' and a state's name, against its column 't'; it has " +
                      columns + " (give --bank to read it as run did)");
        }
      }
    }
    const int panels = 1 + (decision > 0 ? 1 : 0) + (options.states ? static_cast<int>(states.size()) : 0);
    // A log stamped by a clock (a ROS 2 bag's header.stamp, epoch seconds)
    // is drawn from its first row, whose time the axis names: from 0, its
    // minutes would be a sliver at the end of 1.7e9 s, and gnuplot's ticks
    // could not tell its seconds apart.
    const double origin = time_origin(first_t);
    const auto at = [origin](double t) { return CsvWriter::format(t - origin); };
    const std::string x_label = origin > 0.0 ? "set xlabel 'time (s) since t = " + time_text(origin) + " s'\n"
                                             : std::string("set xlabel 'time (s)'\n");
    const auto x_of = [origin](int column) {
      return origin > 0.0 ? "($" + std::to_string(column) + " - " + CsvWriter::format(origin) + ")"
                          : std::to_string(column);
    };

    std::ostringstream g;
    g << "set terminal " << terminal << " size 1100," << (panels == 1 ? 420 : 300 + 220 * panels)
      << " font 'sans,10'\n";
    // gnuplot writes a temporary file, renamed when it succeeded: a failed
    // plot never leaves a truncated figure under the final name.
    const fs::path drawing = options.output.string() + ".partial";
    g << "set output " << file_name(drawing) << "\n";
    g << "set datafile separator ','\nset key outside right noenhanced\nset grid ytics lc rgb '#dddddd'\n";
    g << "set xrange [" << (origin > 0.0 ? "0" : CsvWriter::format(std::min(0.0, first_t))) << ":" << at(last_t)
      << "]\n";
    // Fixed margins so the panels' time axes line up whatever their keys' widths.
    if (panels > 1) {
      std::size_t longest = 0;  // the decision panel's row labels are mode names
      for (const auto& m : modes) longest = std::max(longest, m.second.size());
      g << "set termoption noenhanced\nset lmargin " << std::max<std::size_t>(10, decision > 0 ? longest + 4 : 0)
        << "\nset rmargin 24\nset multiplot layout " << panels << ",1 title " << gnuplot_string(options.title)
        << " noenhanced\n";
    } else
      g << "set title " << gnuplot_string(options.title) << " noenhanced\n";
    // gnuplot's line types cycle through 8 colours, so in a bank of 10 or 16
    // modes two modes would share a colour. Line types from 9 on get 12 more
    // colours, and past 20 modes the colours repeat with another dash pattern.
    // The first 8 stay gnuplot's own, so smaller banks look as they did.
    static const char* const kExtraColours[] = {"#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf", "#aec7e8",
                                                "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#9edae5"};
    static const char* const kFirstColours[] = {"#9400d3", "#009e73", "#56b4e9", "#e69f00",
                                                "#f0e442", "#0072b2", "#e51e10", "#000000"};
    for (std::size_t k = 9; k <= modes.size(); ++k) {
      const std::size_t i = (k - 1) % 20;
      g << "set linetype " << k << " lc rgb '" << (i < 8 ? kFirstColours[i] : kExtraColours[i - 8]) << "' dt "
        << 1 + (k - 1) / 20 << "\n";
    }
    // Mode probabilities, the truth as bands coloured like the mode's line
    // (a class's like its first mode's; a class without the bank, grey, named).
    std::map<std::string, int> line_of;
    for (std::size_t i = 0; i < modes.size(); ++i) line_of[modes[i].second] = static_cast<int>(i) + 1;
    std::map<std::string, int> colour_of = line_of;
    colour_of.insert(first_mode_of_class.begin(), first_mode_of_class.end());
    int object = 1, label = 1;
    for (std::size_t b = 0; b < bands.size(); ++b) {
      if (b > 0)
        g << "set arrow " << b << " from " << at(bands[b].start) << ", graph 0 to " << at(bands[b].start)
          << ", graph 1 nohead dt 2 lc rgb '#444444'\n";
      if (bands[b].mode.empty()) continue;  // an unlabelled stretch
      const auto it = colour_of.find(bands[b].mode);
      const std::string end = at(b + 1 < bands.size() ? bands[b + 1].start : bands[b].end);
      g << "set object " << object++ << " rect from " << at(bands[b].start) << ", graph 0 to " << end
        << ", graph 1 back fc " << (it != colour_of.end() ? "lt " + std::to_string(it->second) : "rgb '#888888'")
        << " fs transparent solid 0.12 noborder\n";
      if (it == colour_of.end()) {
        g << "set label " << label++ << " " << gnuplot_string(bands[b].mode) << " at " << at(bands[b].start)
          << ", graph 0.97 offset 0.5, 0 left front tc rgb '#444444'\n";
      }
    }
    g << "set ylabel 'mode probability'\nset yrange [-0.02:1.05]\n";
    if (panels == 1) g << x_label;
    g << "plot ";
    for (std::size_t i = 0; i < modes.size(); ++i) {
      g << (i ? ", " : "") << file_name(estimates_file) << " using " << x_of(1) << ":" << modes[i].first
        << " with lines lt " << i + 1 << " lw 2 title " << gnuplot_string(modes[i].second);
    }
    g << "\n";
    if (decision > 0) {
      // One row per mode (and `unknown` below them), a bar where the decision
      // held it, coloured like the mode's probability line.
      // The rows are the modes, or, for a bank with classes (whose decision
      // names a class), the classes decided, in order of first appearance.
      std::vector<std::string> rows;
      std::map<std::string, int> row_of;
      bool all_modes = true, any_decided = false;
      for (const Band& d : decisions) {
        all_modes = all_modes && (d.mode == "unknown" || line_of.count(d.mode) > 0);
        any_decided = any_decided || d.mode != "unknown";
      }
      // Never decided: whether the decision would name modes or classes is
      // unknown without the bank, so no row but `unknown` is drawn.
      if (all_modes && any_decided) {
        for (const auto& m : modes) rows.push_back(m.second);
      } else {
        for (const Band& d : decisions) {
          if (d.mode != "unknown" && std::find(rows.begin(), rows.end(), d.mode) == rows.end()) rows.push_back(d.mode);
        }
      }
      for (std::size_t i = 0; i < rows.size(); ++i) row_of[rows[i]] = static_cast<int>(i) + 1;
      g << "unset object\nunset arrow\nunset label\nset ylabel 'decision'\n";
      g << "set ytics (" << gnuplot_string("unknown") << " 0";
      for (std::size_t i = 0; i < rows.size(); ++i) g << ", " << gnuplot_string(rows[i]) << " " << i + 1;
      g << ")\nset yrange [-0.6:" << rows.size() + 0.6 << "]\n";
      if (panels == 2) g << x_label;
      for (std::size_t b = 0; b < decisions.size(); ++b) {
        const auto it = row_of.find(decisions[b].mode);
        const int row = it == row_of.end() ? 0 : it->second;
        const double end = b + 1 < decisions.size() ? decisions[b + 1].start : decisions[b].end;
        // A mode's row in its line's colour, a class's in its first mode's;
        // a class without the bank in dark grey, not in some mode's colour.
        const auto colour = colour_of.find(decisions[b].mode);
        const std::string fill = row == 0                    ? "rgb '#999999'"
                                 : colour != colour_of.end() ? "lt " + std::to_string(colour->second)
                                                             : "rgb '#555555'";
        g << "set object " << object++ << " rect from " << at(decisions[b].start) << ", " << row - 0.35 << " to "
          << at(end) << ", " << row + 0.35 << " front fc " << fill << " fs solid 0.9 noborder\n";
      }
      for (std::size_t b = 1; b < bands.size(); ++b) {
        g << "set arrow " << b << " from " << at(bands[b].start) << ", graph 0 to " << at(bands[b].start)
          << ", graph 1 nohead dt 2 lc rgb '#444444'\n";
      }
      g << "plot NaN notitle\nset ytics autofreq\n";
    }
    if (panels > 1 && options.states) {
      g << "unset object\nunset arrow\nunset label\nset yrange [*:*]\n";
      for (std::size_t s = 0; s < states.size(); ++s) {
        if (s + 1 == states.size()) g << x_label;
        g << "set ylabel " << gnuplot_string(states[s]) << "\nplot " << file_name(estimates_file) << " using "
          << x_of(1) << ":" << column_of(header, states[s]) << " with lines lw 2 lc rgb '#1f77b4' title 'estimate'";
        const int measured = column_of(log_header, states[s]);
        const int true_state = column_of(log_header, "true_" + states[s]);
        const int time = column_of(log_header, "t");
        if (measured > 0 && time > 0) {
          g << ", " << file_name(log_file) << " using " << x_of(time) << ":" << measured
            << " with points pt 7 ps 0.3 lc rgb '#999999' title 'measured'";
        }
        if (true_state > 0 && time > 0) {
          g << ", " << file_name(log_file) << " using " << x_of(time) << ":" << true_state
            << " with lines dt 2 lw 1.5 lc rgb '#d62728' title 'true'";
        }
        g << "\n";
      }
    }
    if (panels > 1) g << "unset multiplot\n";

    const fs::path script = options.output.string() + ".gnuplot";
    write_file_atomically(script, g.str());
    temporary.push_back(script);
    const fs::path errors = script.string() + ".err";
    const int status = run_gnuplot(gnuplot, script, errors);
    std::ifstream err(errors);
    const std::string messages((std::istreambuf_iterator<char>(err)), std::istreambuf_iterator<char>());
    err.close();
    std::error_code ec;
    fs::remove(errors, ec);
    if (status != 0 || !fs::exists(drawing, ec) || fs::file_size(drawing, ec) == 0) {
      fs::remove(drawing, ec);
      temporary.keep();  // the script and its data, to rerun gnuplot by hand
      throw Error("gnuplot failed on " + script.string() + (status < 0 ? " (it could not be started)" : "") + ":\n" +
                  messages);
    }
    fs::rename(drawing, options.output, ec);
    if (ec) {
      fs::remove(drawing, ec);
      throw Error(options.output.string() + ": cannot rename " + drawing.string() + " to it: " + ec.message());
    }
    return kExitOk;
  });
}

}  // namespace cli
}  // namespace skidimm
