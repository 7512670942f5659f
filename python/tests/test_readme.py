"""The README stays short and agrees with the program: under 1,200 words outside code blocks,
and its lists of built-in scenes, generators, methods and matrix formats are the ones
`formfactor --help` prints; every option --help lists is in the docs."""

import re

from conftest import SOURCE_DIR, run_cli

README = SOURCE_DIR / "README.md"


def words_outside_code(text):
    text = re.sub(r"^(\s*)(`{3,}|~{3,}).*?^\1\2\s*$", "", text, flags=re.S | re.M)
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link counts as its text
    return [w for w in text.split() if re.search(r"\w", w)]


def test_the_readme_is_under_1200_words_outside_code_blocks():
    n = len(words_outside_code(README.read_text()))
    assert n <= 1200, "README.md has %d words outside code blocks (at most 1,200)" % n


def test_word_counting_leaves_out_code_comments_and_link_targets():
    text = "One two.\n\n```sh\nthree four five\n```\n<!-- six -->\n[seven](docs/x.md) | - |\n"
    assert words_outside_code(text) == ["One", "two.", "seven"]


def readme_list(label):
    """The backticked names of the README's line `- **LABEL:** ...`."""
    lines = [l for l in README.read_text().split("\n") if l.startswith("- **%s:**" % label)]
    assert len(lines) == 1, "README.md needs one line '- **%s:** ...'" % label
    return re.findall(r"`([^`]+)`", lines[0])


def help_line(text, prefix):
    lines = [l.strip() for l in text.split("\n") if l.strip().startswith(prefix)]
    assert len(lines) == 1, "formfactor --help needs one line starting with %r" % prefix
    return lines[0][len(prefix):]


def test_the_readme_lists_what_help_lists():
    text = run_cli("--help").stdout
    scenes = help_line(text, "built-in scenes:").split(",")
    generators = help_line(text, "generators:").split("(")[0].split(",")
    methods = help_line(text, "Methods (--method):").split(",")
    formats = re.findall(r"\.\w+", help_line(text, "Matrix formats (-o, --matrix):"))
    scene_files = re.findall(r"\.[a-z]\w*", help_line(text, "Scenes (SCENE):"))
    for label, listed in [("Scene files", scene_files), ("Built-in scenes", scenes),
                          ("Generators", generators),
                          ("Methods", methods), ("Matrix formats", formats)]:
        listed = sorted(x.strip() for x in listed if x.strip())
        assert len(listed) >= 2, (label, text)
        assert sorted(readme_list(label)) == listed, \
            "README.md's '%s' line differs from formfactor --help" % label


def test_help_names_every_scene_the_program_loads():
    """Every name --help lists loads (generators with N = 2), and --version names the licence."""
    text = run_cli("--help").stdout
    for name in help_line(text, "built-in scenes:").split(","):
        run_cli("info", name.strip())
    for g in help_line(text, "generators:").split("(")[0].split(","):
        run_cli("info", g.strip().replace("N", "2"))
    assert "MIT" in run_cli("--version").stdout


def test_every_option_of_help_is_in_the_docs():
    """Each subcommand's options, as --help lists them, appear in README.md or docs/*.md."""
    docs = README.read_text() + "".join(p.read_text() for p in (SOURCE_DIR / "docs").glob("*.md"))
    subcommands = re.findall(r"^  (\w+) {2,}", run_cli("--help").stdout.split("Subcommands:")[1],
                             flags=re.M)
    assert "compute" in subcommands and "solve" in subcommands
    missing = []
    for sub in subcommands:
        for line in run_cli(sub, "--help").stdout.split("\n"):
            m = re.match(r"^\s+(-[\w-]+(?:,-[\w-]+)*)", line)
            for option in (m.group(1).split(",") if m else []):
                if option.startswith("--") and option != "--help" and option not in docs:
                    missing.append("%s %s" % (sub, option))
    assert not missing, "options of --help missing from the docs: " + ", ".join(missing)


def test_every_relative_link_of_the_docs_exists():
    """[text](path) links of README.md and docs/*.md to files of the tree lead somewhere."""
    pages = [README] + sorted((SOURCE_DIR / "docs").glob("*.md"))
    broken = []
    for page in pages:
        for n, line in enumerate(page.read_text().split("\n"), 1):
            for target in re.findall(r"\]\(([^)\s]+)\)", line):
                if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                    continue  # a URL or an anchor
                if not (page.parent / target.split("#")[0]).exists():
                    broken.append("%s:%d: %s" % (page.relative_to(SOURCE_DIR), n, target))
    assert not broken, "links to files that do not exist:\n" + "\n".join(broken)
