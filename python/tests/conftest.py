"""Shared fixtures: the project root, the corpus and the `isoc` CLI binary."""

import os
import shutil
import signal
from pathlib import Path

import pytest

# A shell starts background jobs with SIGINT ignored, and Python then keeps
# it ignored: the Ctrl-C tests need the interpreter's own handler back.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

ROOT = Path(__file__).resolve().parents[2]
CORPUS = sorted((ROOT / "corpus").glob("*.iso"))


def expected(path):
    """`(components, genus)` from the file's `# expect:` line, None if singular."""
    for line in path.read_text().splitlines():
        if line.startswith("# expect:"):
            words = dict(w.split("=", 1) for w in line[len("# expect:"):].split() if "=" in w)
            if "components" not in words:
                return None
            return int(words["components"]), int(words["genus"])
    return None


@pytest.fixture(scope="session")
def isoc_bin():
    """The CLI binary: $ISOC_BIN, else target/release or target/debug."""
    for cand in [os.environ.get("ISOC_BIN"), ROOT / "target/release/isoc", ROOT / "target/debug/isoc",
                 shutil.which("isoc")]:
        if cand and Path(cand).is_file():
            return str(cand)
    pytest.fail("no isoc binary: build it (cargo build) or set ISOC_BIN")
