"""The command lines benchmarks.checks.same_outputs runs with two versions of bkflow: every
subcommand's help, run in every scene and protocol, analyze, deck, sweep, plot, collect, movie,
and the refusals with their exit codes (``CASES``: name, steps)."""

from __future__ import annotations

RUN = ("run", "--phi", "10", "--size", "8x3", "--t-end", "200")
PAPER = (*RUN, "--protocol", "paper")
#: a steady run that stops by its rule (at t = 1500) before its cap
RULED = ("run", "--phi", "1", "--size", "8x3", "--target-error", "0.02", "--out", "q")
DECK = ("deck", "--phi", "10", "--size", "8x3", "--t-end", "200")
SUBCOMMANDS = ("run", "deck", "sweep", "collect", "plot", "analyze", "movie")
SWEEP = ("sweep", "--phi", "1,10", "--sizes", "12x3", "--seeds", "1", "--out", "s",
         "--t-end", "200")


out = lambda *args, to="r": (*args, "--out", to)
#: ``args`` asking for another ``--t-end``
t_end = lambda args, t: tuple(t if p == "--t-end" else x for p, x in zip(("",) + args, args))
#: a step that writes a file of the user's (no bkflow)
write = lambda rel, text="mine\n": ("+write", rel, text)


#: (name, steps): a step is bkflow's arguments, or ``write(...)``
CASES: list[tuple[str, list]] = [
    ("help", [("--help",)]), ("version", [("--version",)]), ("no-args", [()]),
    *((f"help-{c}", [(c, "--help")]) for c in SUBCOMMANDS),
    ("run-default", [out(*RUN)]),
    *((f"run-{scene}", [out(*RUN, "--scene", scene)]) for scene in ("friction", "series", "full")),
    ("run-paper", [out(*PAPER)]),
    ("run-steady", [out(*RUN, "--protocol", "steady", "--accuracy", "fast", "--scene", "order",
                        "--seed", "3", "--contact-rule", "coulomb", "--set", "gamma=0.1")]),
    ("run-general-path", [out(*PAPER, "--path", "general", "--scene", "clusters")]),
    ("run-n-quiet", [out("run", "--phi", "100", "--n", "100", "--t-end", "100", "--protocol",
                         "paper", "--quiet", to="sub/r")]),
    ("run-then-analyze", [out(*RUN, "--no-analyze"), ("analyze", "r")]),
    ("analyze-settings", [out(*PAPER), ("analyze", "r", "--analysis", "n_blocks=5"),
                          out(*PAPER)]),
    ("run-analysis-left", [out(*RUN, "--no-analyze"), out(*RUN)]),
    ("run-again-finished", [out(*RUN), out(*RUN)]),
    ("run-other-into-finished", [out(*RUN), out("run", "--phi", "11", *RUN[3:])]),
    ("run-overwrite", [out(*PAPER), out(*PAPER, "--seed", "2", "--overwrite")]),
    ("run-continue", [out(*PAPER), out(*t_end(PAPER, "400"))]),
    ("run-shorter", [out(*PAPER), out(*t_end(PAPER, "100"))]),
    # asked again with a longer cap: answered, nothing runs; the last two caps above the cost
    # limits (atom-steps; memory) of a run that is not made
    ("run-answered", [(*RULED, "--t-end", t) for t in ("2000", "4000", "1.5e8", "4e8")]),
    ("run-cost-refused", [out("run", "--phi", "10", "--n", "100", "--t-end", "1e8",
                              "--protocol", "paper")]),
    ("run-foreign-dir", [write("f/notes.txt"), out(*RUN, to="f")]),
    ("run-into-deck", [out(*DECK, to="d"), out(*RUN, to="d")]),
    ("run-out-is-file", [write("f"), out(*RUN, to="f")]),
    *((f"bad-{what}", [out("run", *args)]) for what, args in (
        ("phi-negative", ("--phi", "-1", "--size", "8x3")), ("phi-text", ("--phi", "abc")),
        ("phi-zero", ("--phi", "0", "--size", "8x3")), ("n", ("--phi", "1", "--n", "7")),
        ("size", ("--phi", "1", "--size", "2x3")), ("dt-factor", (*RUN[1:], "--dt-factor", "3")),
        ("option", (*RUN[1:], "--bogus")), ("abbreviation", (*RUN[1:], "--over")),
        *((f"set-{k}", (*RUN[1:], "--set", v)) for k, v in (
            ("name", "nosuch=1"), ("form", "gamma"), ("value", "gamma=abc"), ("phi", "phi=3"))))),
    ("missing-out", [RUN]),
    ("analyze-missing", [("analyze", "nope")]),
    ("analyze-foreign", [write("f/notes.txt"), ("analyze", "f")]),
    ("analyze-bad-setting", [out(*PAPER, "--no-analyze"),
                             ("analyze", "r", "--analysis", "nosuch=1")]),
    ("deck", [out(*DECK, to="d")]),
    ("deck-paper-full", [out(*DECK, "--protocol", "paper", "--scene", "full", to="d")]),
    ("deck-companion", [out(*DECK, "--companion", "partial", to="d")]),
    ("deck-set-companion", [out(*DECK, "--set", "companion=partial", to="d")]),
    ("deck-foreign-dir", [write("f/notes.txt"), out(*DECK, to="f")]),
    ("deck-twice", [out(*DECK, to="d"), out(*DECK, to="d")]),
    ("sweep-plot", [SWEEP, ("plot", "s"), ("collect", "s"), SWEEP,
                    ("plot", "s", "--where", "phi=10", "--format", "png", "--out", "fig"),
                    t_end(SWEEP, "400"), ("plot", "s")]),
    ("sweep-shorter", [SWEEP, t_end(SWEEP, "100")]),
    ("sweep-bad-range", [out("sweep", "--phi", "1e3:1e-1", to="s")]),
    ("sweep-bad-aspect", [out("sweep", "--phi", "1,10", "--sizes", "7x3", to="s")]),
    ("sweep-jobs-0", [out("sweep", "--phi", "1,10", "--jobs", "0", to="s")]),
    ("sweep-foreign-dir", [write("s/notes.txt"), SWEEP]),
    ("sweep-init", [(*SWEEP, "--init")]),
    ("plot-run", [out(*PAPER), ("plot", "r")]),
    ("plot-run-where", [out(*PAPER), ("plot", "r", "--where", "phi=10")]),
    ("plot-missing", [("plot", "nope")]), ("collect-missing", [("collect", "nope")]),
    ("movie", [out(*PAPER, "--scene", "fronts"), ("movie", "r"),
               ("movie", "r", "--slip", "1", "--fps", "5", "--out", "r/two.gif")]),
    ("movie-no-fronts", [out(*PAPER, "--scene", "friction"), ("movie", "r")]),
    ("movie-bad-fps", [("movie", "r", "--fps", "100")]),
]
