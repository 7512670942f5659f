"""The documentation's examples with the expensive ones (marked `<!-- test: slow -->`) run too:
ctest label `slow` (docs/testing.md)."""

import pytest

from conftest import BUILD_DIR, SOURCE_DIR
from doc_examples import DocExampleError, doc_pages, parse_blocks, run_page

SLOW_PAGES = [p for p in doc_pages(SOURCE_DIR)
              if any(b.marker == "slow" for b in parse_blocks(p.read_text(), p.name))]


@pytest.mark.parametrize("page", SLOW_PAGES, ids=[p.name for p in SLOW_PAGES])
def test_the_examples_of_a_page_run_with_the_slow_ones(page, tmp_path):
    error = None
    try:
        run_page(page, SOURCE_DIR, BUILD_DIR, tmp_path / "work", slow=True)
    except DocExampleError as e:
        error = str(e)
    if error:  # outside the handler: one message, no exception chain
        pytest.fail(error, pytrace=False)
