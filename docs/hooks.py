"""MkDocs hook: the pages that live beside the code they describe (the reproduction, the
benchmarks, the changelog) and their figures join the site under their repository paths, so
that their own relative links and images work there as they do on disk."""

from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
PAGES = ("CHANGELOG.md", "benchmarks/RESULTS.md", "workflows/paper/REPRODUCTION.md",
         "workflows/paper/numbers.md")
IMAGES = ("benchmarks/*.png", "workflows/paper/figures/**/*.png")


def on_files(files, config):
    paths = list(PAGES) + sorted(p.relative_to(ROOT).as_posix() for pattern in IMAGES
                                 for p in ROOT.glob(pattern))
    for rel in paths:
        files.append(File(rel, str(ROOT), config["site_dir"], config["use_directory_urls"]))
    files.append(File.generated(config, "cli.md", content=_cli_page()))
    return files


def _cli_page() -> str:
    """docs' cli.md, from the program itself: the help of every command, and the exit codes."""
    from bkflow.cli.guards import EXIT_CODES
    from bkflow.cli.parser import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    out = ["# Command line", "",
           "Generated from `bkflow --help` when the site is built, so it is always the "
           "program's own.", "", "```", parser.format_help().rstrip(), "```", ""]
    for name, p in sub.choices.items():
        out += [f"## bkflow {name}", "", "```", p.format_help().rstrip(), "```", ""]
    out += ["## Exit codes", "", "| code | meaning |", "|---|---|"]
    out += [f"| {code} | {what} |" for code, what in EXIT_CODES.items()]
    return "\n".join(out) + "\n"
