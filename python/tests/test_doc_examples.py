"""Every shell and Python example of README.md and docs/*.md runs and exits 0 (the runner and
its markers: doc_examples.py, docs/testing.md). Examples marked `slow` run in
test_doc_examples_slow.py (ctest label `slow`)."""

import pytest

from conftest import BUILD_DIR, SOURCE_DIR
from doc_examples import DocExampleError, doc_pages, parse_blocks, run_page

PAGES = doc_pages(SOURCE_DIR)


@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_the_examples_of_a_page_run(page, tmp_path):
    error = None
    try:
        run_page(page, SOURCE_DIR, BUILD_DIR, tmp_path / "work", slow=False)
    except DocExampleError as e:
        error = str(e)
    if error:  # outside the handler: one message, no exception chain
        pytest.fail(error, pytrace=False)


def test_the_readme_and_docs_have_examples_to_run():
    langs = [b.lang for p in PAGES for b in parse_blocks(p.read_text(), p.name)]
    assert langs.count("sh") + langs.count("console") >= 5
    assert langs.count("python") >= 3


def test_every_file_an_example_names_exists_in_examples():
    """An example that reads examples/NAME finds it (a typo fails here, before any run)."""
    import re
    missing = []
    for p in PAGES:
        for b in parse_blocks(p.read_text(), p.name):
            for name in re.findall(r"examples/([\w.-]+)", b.code + b.marker_text):
                if not (SOURCE_DIR / "examples" / name).exists():
                    missing.append("%s: examples/%s" % (b.where, name))
    assert not missing, "files the examples name but examples/ lacks:\n" + "\n".join(missing)


# The runner itself: a failing example is reported with its page and line.

PAGE = """# A page

Text.

```sh
true
false
```
"""


def test_a_failing_shell_example_names_its_page_and_line(tmp_path):
    page = tmp_path / "src" / "docs" / "page.md"
    page.parent.mkdir(parents=True)
    page.write_text(PAGE)
    with pytest.raises(DocExampleError, match=r"^docs/page\.md:7: this command exited 1"):
        run_page(page, tmp_path / "src", BUILD_DIR, tmp_path / "work")


def test_a_failing_python_example_names_its_page_and_line(tmp_path):
    page = tmp_path / "src" / "README.md"
    page.parent.mkdir(parents=True)
    page.write_text("x\n\n```python\na = 1\nb = a / 0\n```\n")
    with pytest.raises(DocExampleError, match=r"^README\.md:5: ZeroDivisionError"):
        run_page(page, tmp_path / "src", BUILD_DIR, tmp_path / "work")


def test_markers_skip_replace_and_prepare_blocks(tmp_path):
    page = tmp_path / "src" / "README.md"
    page.parent.mkdir(parents=True)
    page.write_text(
        "<!-- test: skip it would install packages -->\n```sh\nfalse\n```\n"
        "<!-- test: instead\ntouch small.txt\n-->\n```sh\nfalse\n```\n"
        "<!-- test: setup\nopen('n.txt', 'w').write('2')\n-->\n```python\nn = int(open('n.txt').read())\n```\n"
        "```console\n$ test -f small.txt && \\\n  test $(cat n.txt) = 2\nsome output\n```\n"
        "<!-- test: slow -->\n```sh\nfalse\n```\n")
    assert run_page(page, tmp_path / "src", BUILD_DIR, tmp_path / "work") == 3
    with pytest.raises(DocExampleError, match=r"^README\.md:24: this command exited 1"):
        run_page(page, tmp_path / "src", BUILD_DIR, tmp_path / "work2", slow=True)


def test_an_unknown_or_incomplete_marker_is_an_error(tmp_path):
    for text, message in [("<!-- test: sometimes -->\n```sh\ntrue\n```\n", r"README\.md:1: unknown"),
                          ("<!-- test: skip -->\n```sh\ntrue\n```\n", r"README\.md:1: .*reason"),
                          ("```sh\ntrue\n", r"README\.md:1: code block never closed")]:
        with pytest.raises(DocExampleError, match=message):
            parse_blocks(text, "README.md")
