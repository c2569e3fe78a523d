"""Issue 11, item 2: every input of the malformed corpus (tests/data/malformed_corpus.py) goes through
``pavement-mcmc fit``: the ones to refuse exit 2 with one message naming the file (and the
column / row where they apply), no traceback and no output folder; the ones to accept (BOM,
CRLF, shuffled or extra columns, one irregular step) start a fit, and an ignored column is
said as a plain warning line, not a Python warning with its source line."""

from __future__ import annotations

import pytest
from malformed_corpus import CORPUS, classify, run


def test_corpus_is_large_enough():
    assert len(CORPUS) >= 30
    assert len({e.name for e in CORPUS}) == len(CORPUS)


@pytest.mark.parametrize("entry", CORPUS, ids=[e.name for e in CORPUS])
def test_malformed_input(entry, tmp_path):
    code, err, left = run(entry, tmp_path)
    cats = classify(entry, code, err, left)
    assert "traceback" not in cats, err
    if entry.refuse:
        assert cats == ["clean error"], (cats, err)
        assert err.count("error:") == 1
    else:
        assert cats == ["accepted"], (cats, err)


def test_semicolon_file_says_so(tmp_path):
    entry = next(e for e in CORPUS if e.name == "semicolon_decimal_comma")
    code, err, _ = run(entry, tmp_path)
    assert code == 2 and "looks ';'-separated with decimal commas" in err
