// docs/formats-mesh.md: every command of its worked examples runs as written (from a folder
// that looks like the repository's top: examples/, tests/ and build/bin/formfactor).

#include <doctest/doctest.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "support/cli_runner.h"
#include "support/temp_dir.h"

using formfactor::testing::read_text;
using formfactor::testing::shell_quote;
using formfactor::testing::TempDir;

TEST_CASE("docs: every command of the mesh formats page runs") {
    namespace fs = std::filesystem;
    const fs::path source = fs::path(FF_TEST_DATA_DIR).parent_path().parent_path();
    const std::string page = read_text((source / "docs" / "formats-mesh.md").string());
    REQUIRE_FALSE(page.empty());
    std::vector<std::string> commands;
    std::istringstream in(page);
    bool inside = false;
    for (std::string line; std::getline(in, line);) {
        if (line.rfind("```", 0) == 0) {
            inside = !inside && line == "```sh";
            continue;
        }
        if (inside && !line.empty()) commands.push_back(line);
    }
    REQUIRE(commands.size() >= 10);
    const TempDir dir;
    fs::create_directories(dir.path() / "build" / "bin");
    fs::create_directory_symlink(source / "examples", dir.path() / "examples");
    fs::create_directory_symlink(source / "tests", dir.path() / "tests");
    fs::create_symlink(FF_CLI_PATH, dir.path() / "build" / "bin" / "formfactor");
    for (const std::string& c : commands) {
        INFO(c);
        // The line may end in a comment: it goes on a line of its own.
        const std::string cmd = "cd " + shell_quote(dir.path().string()) + " && {\n" + c +
                                "\n} > " + shell_quote(dir.file("out.txt")) + " 2>&1";
        const int status = std::system(cmd.c_str());
        INFO(read_text(dir.file("out.txt")));
        CHECK(status == 0);
    }
    CHECK(fs::exists(dir.path() / "room.msh"));
    CHECK(read_text(dir.file("out.txt")).find("12 faces merged into 6 surfaces") !=
          std::string::npos);
}
