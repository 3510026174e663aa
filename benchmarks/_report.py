"""Shared by the benchmark scripts: print a report and save it."""

import os


def save_report(text: str, path: str) -> None:
    print(text)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as fh:
        fh.write(text.rstrip("\n") + "\n")
