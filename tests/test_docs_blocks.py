"""The rules by which tests/test_docs_run.py compares what a page shows with what runs."""

from __future__ import annotations

from pathlib import Path

from tests.docs_blocks import blocks, compare, console_commands


def test_json_is_compared_value_by_value() -> None:
    live = '{"plan_id": "ab12", "n": 6.697889, "poses": [1, 2, 3, 4], "ok": true, "s": "goal x"}'
    shown = '{"plan_id": "zz", "n": 6.698, "poses": [1, "…", 4], "ok": true, "s": "goal…"}'
    assert compare(shown, live) == []  # ids skipped, numbers to the decimals shown
    assert compare('{"n": 6.69, "…": "…"}', live)  # 6.697889 is not 6.69
    assert compare('{"n": 6.698}', live)  # members live but not shown, without "…": "…"
    assert compare('{"n": 6.698, "ok": 1, "…": "…"}', live)  # true is not 1
    assert compare('{"poses": [1, "…", 3], "…": "…"}', live)  # the last element differs
    assert compare('{"x": 1, "…": "…"}', live)  # shown but not live


def test_json_values_one_after_another_and_text_line_by_line() -> None:
    assert compare('{"a": 1}\n204\n{"b": [2]}', '{"a":1}204\n{"b":[2]}') == []
    assert compare('{"a": 1}\n{"b": 2}', '{"a":1}')  # a value missing
    assert compare("wrote …\n…\ndone", "wrote a.png\nx\ny\ndone") == []
    assert compare("wrote …\ndone", "wrote a.png\nx\ndone")


def test_a_console_block_is_commands_and_what_they_print() -> None:
    text = "$ echo 'a\n  b'\na\n  b\n$ ls \\\n    -l\ntotal 0\n$ true\n"
    assert console_commands(text) == [
        ("echo 'a\n  b'\n", "a\n  b"),
        ("ls \\\n    -l\n", "total 0"),
        ("true\n", ""),
    ]


def test_an_output_block_follows_its_command(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text(
        "```sh\necho 1\n```\n\n```json\n1\n```\n\nprose\n\n```json\n2\n```\n\n"
        "```sh notest\nmake run\n```\n"
    )
    first, second, third, fourth = blocks(page)
    assert first.runs
    assert first.output is not None
    assert first.output.text == "1\n"
    assert not second.runs
    assert third.output is None  # after prose: no command's
    assert not fourth.runs
