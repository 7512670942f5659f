#pragma once
// Runs the `formfactor` binary (FF_CLI_PATH) for end-to-end tests: in a working directory of
// the test's own, with stdout and stderr captured to files outside it.

#include <sys/wait.h>

#include <cstdlib>
#include <string>

#include "temp_dir.h"

namespace formfactor::testing {

struct CliResult {
    int code = -1;    ///< exit code
    std::string out;  ///< standard output
    std::string err;  ///< standard error
    /// True when stderr is exactly one line "formfactor: ...".
    bool one_error_line() const {
        return err.rfind("formfactor: ", 0) == 0 && err.find('\n') == err.size() - 1;
    }
};

inline std::string shell_quote(const std::string& s) {
    std::string q = "'";
    for (char c : s) {
        if (c == '\'')
            q += "'\\''";
        else
            q += c;
    }
    return q + "'";
}

/// A working directory plus a capture directory; run() executes `formfactor ARGS` in the
/// working directory (ARGS is shell text: quote paths with shell_quote when needed).
class Cli {
  public:
    CliResult run(const std::string& args) const {
        const std::string out = capture_.file("stdout.txt");
        const std::string err = capture_.file("stderr.txt");
        const std::string cmd = "cd " + shell_quote(work_.path().string()) + " && " +
                                shell_quote(FF_CLI_PATH) + " " + args + " > " + shell_quote(out) +
                                " 2> " + shell_quote(err) + " < /dev/null";
        const int status = std::system(cmd.c_str());
        CliResult r;
        r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        r.out = read_text(out);
        r.err = read_text(err);
        return r;
    }
    /// The working directory.
    const TempDir& dir() const { return work_; }
    std::string file(const std::string& name) const { return work_.file(name); }
    /// Writes a file into the working directory.
    void write(const std::string& name, const std::string& text) const {
        write_text(work_.file(name), text);
    }

  private:
    TempDir work_;
    TempDir capture_;
};

}  // namespace formfactor::testing
