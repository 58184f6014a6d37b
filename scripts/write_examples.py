"""Writes examples/*.toml from their one definition, the builders of flextop.scenes.

    python scripts/write_examples.py           # rewrite the files
    python scripts/write_examples.py --check   # exit 1 if a file is not what the builders give
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if list((ROOT / "python" / "flextop").glob("_core*")):  # this checkout's package, built in place
    sys.path.insert(0, str(ROOT / "python"))

from flextop.scenes import EXAMPLES, example_toml  # noqa: E402

EXAMPLES_DIR = ROOT / "examples"


def main(argv: list[str]) -> int:
    stale = []
    for name in EXAMPLES:
        path, text = EXAMPLES_DIR / name, example_toml(name)
        if path.exists() and path.read_text(encoding="utf-8") == text:
            continue
        stale.append(path)
        if "--check" not in argv:
            path.write_text(text, encoding="utf-8")
            print(f"wrote {path}")
    if "--check" in argv and stale:
        print("out of date (run python scripts/write_examples.py):", *map(str, stale), sep="\n  ")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
