"""The command line's one-line errors, checked the same way by every CLI test."""
from catadioptric.cli import main


def error_line(capsys) -> str:
    """The one line ``catadioptric: error: ...`` the command printed on stderr (no traceback)."""
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("catadioptric: error: ")
    return lines[0]


def fails(argv, capsys) -> str:
    """Run ``catadioptric ARGV``; it must exit 2 with one error line, which is returned."""
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse's own checks
        rc = exc.code
    assert rc == 2
    return error_line(capsys)
