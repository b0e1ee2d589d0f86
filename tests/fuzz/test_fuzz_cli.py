"""Fuzz the command line in-process: ``ltvmodels.cli.main(argv)`` with fuzzed argument
lists and fuzzed data and model files.

What is fuzzed
--------------
* **CSV contents** (:class:`CsvFile`): the data of a :class:`fuzz_strategies.Data`
  recipe written with or without a header, with comma/semicolon/tab
  separators, missing-value tokens (empty, NA, nan, null), infinities, words
  in numeric columns, ragged rows, comments, a byte-order mark, CRLF line
  ends, blank lines, quoted fields, duplicate column names — or random text
  or bytes. ``-`` reads the same text from standard input.
* **Arguments** for ``fit``, ``segments``, ``ar``, ``select-lambda``,
  ``simulate``, ``predict`` (and ``demo`` with options that must be
  rejected before any work): column selections by name and index, valid
  and invalid, every option with valid and invalid values, unknown options,
  ``--out``/``--plot`` paths that can and cannot be written, ``--json``.
* **Model files** for ``simulate``/``predict``: written by ``ltvmodels fit``
  / ``ar`` on clean data, or damaged (:func:`fuzz_strategies.model_files`).

The oracle (:func:`check_cli`) accepts exit status 0 with a report whose
numbers are finite (no ``nan``/``inf`` in the text, strict JSON with
``--json``; the documented exceptions are a diverging simulation, announced
by a ``DivergenceWarning`` line, and ``None``/``null`` for quantities that do
not exist), with only library warnings on stderr, and with the files it
reports written (a written model must load); or exit status 2 (1 tolerated)
with one ``error:`` line on stderr and no traceback. An exception escaping
``main`` is a failure.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import sys
import time
from dataclasses import dataclass

import numpy as np
from fuzz_oracle import OUTCOMES, FuzzFailure, check_call, strict_json, tmpdir
from fuzz_strategies import Data, ModelFile, datasets, fuzz_test, model_files
from hypothesis import strategies as st

import ltvmodels as ltv

CSV_STYLES = ["plain"] * 6 + [
    "no_header",
    "semicolon",
    "tab",
    "missing_tokens",
    "inf_token",
    "word",
    "ragged",
    "comments",
    "bom",
    "crlf",
    "blank_lines",
    "quoted",
    "dup_names",
    "random_text",
    "random_bytes",
    "empty",
    "header_only",
    "spaces",
    "extra_text_column",
    "numeric_header",
    "latin1",
    "huge_numbers",
    "hex_floats",
    "nan_tokens_only",
]


@dataclass(frozen=True)
class CsvFile:
    """Recipe of a CSV data file: the data of ``data`` written in ``style``."""

    data: Data
    style: str = "plain"
    seed: int = 0

    @property
    def names(self) -> list[str]:
        return [f"x{i + 1}" for i in range(self.data.n)] + [f"u{j + 1}" for j in range(self.data.m)]

    def content(self) -> bytes:
        rng = np.random.default_rng(self.seed)
        style = self.style
        if style == "random_bytes":
            return rng.bytes(int(rng.integers(0, 300)))
        if style == "empty":
            return b""
        x, u = self.data.clean()
        if x.ndim == 3:
            x, u = x[0], (None if u is None else u[0])
        cols = (
            x
            if u is None
            else np.column_stack(
                [x, u[: len(x)]] if len(u) == len(x) else [x, np.resize(u, (len(x), u.shape[1]))]
            )
        )
        names = self.names
        sep = {"semicolon": ";", "tab": "\t"}.get(style, ",")

        def fmt(v: float) -> str:
            if np.isnan(v):
                return (
                    ["", "NA", "nan", "null", "N/A"][int(rng.integers(0, 5))]
                    if style in ("missing_tokens", "nan_tokens_only")
                    else "nan"
                )
            if np.isinf(v):
                return "inf" if v > 0 else "-inf"
            if style == "hex_floats":
                return float(v).hex()
            return repr(float(v))

        rows = [[fmt(v) for v in row] for row in cols]
        if style == "missing_tokens" and rows:
            for r in range(0, len(rows), 3):
                rows[r][int(rng.integers(0, len(rows[r])))] = ["", "NA", "null"][r % 3]
        if style == "nan_tokens_only":
            rows = [["NA"] * len(names) for _ in rows]
        if style == "inf_token" and rows:
            rows[len(rows) // 2][0] = "inf"
        if style == "word" and rows:
            rows[len(rows) // 2][0] = "abc"
        if style == "ragged" and rows:
            rows[len(rows) // 2] = rows[len(rows) // 2][:-1] or ["1", "2"]
        if style == "huge_numbers" and rows:
            rows[0][0] = "1e308"
            rows[-1][-1] = "-1e308"
        header = list(names)
        if style == "dup_names" and len(header) > 1:
            header[1] = header[0]
        if style == "numeric_header":
            header = [str(i) for i in range(len(header))]
        if style == "extra_text_column":
            header.append("label")
            rows = [r + [f"item {i}"] for i, r in enumerate(rows)]
        if style == "quoted":
            header = [f'"{h}"' for h in header]
            rows = [[f'"{v}"' for v in r] for r in rows]
        if style == "spaces":
            header = [f" {h} " for h in header]
            rows = [[f"  {v} " for v in r] for r in rows]
        lines = [] if style in ("no_header",) else [sep.join(header)]
        if style == "header_only":
            lines = [sep.join(header)]
        else:
            lines += [sep.join(r) for r in rows]
        if style == "comments":
            lines = ["# recorded by a fuzzer", *lines[:3], "# middle", *lines[3:]]
        if style == "blank_lines":
            lines = [line for pair in zip(lines, [""] * len(lines), strict=True) for line in pair]
        text = ("\r\n" if style == "crlf" else "\n").join(lines) + "\n"
        if style == "random_text":
            text = "".join(chr(int(c)) for c in rng.integers(32, 0x2FF, size=80))
        if style == "bom":
            text = "\ufeff" + text
        if style == "latin1":
            return text.replace("x1", "x\xe91").encode("latin-1")
        return text.encode("utf-8")


@st.composite
def csv_files(draw, *, T=None, n=None, m=None) -> CsvFile:
    data = draw(datasets(batch=False, forms=False, max_T=50, max_n=3))
    if T is not None or n is not None or m is not None:
        data = Data(
            T if T is not None else data.T,
            n if n is not None else data.n,
            m if m is not None else data.m,
            data.seed,
            0,
            data.scale,
            data.u_scale,
            data.defects,
        )
    return CsvFile(data, draw(st.sampled_from(CSV_STYLES)), draw(st.integers(0, 1000)))


# ---------------------------------------------------------------------------- arguments


def _columns(draw, names: list[str], picked: list[int], *, valid: bool) -> str:
    """A --state/--input value: the ``picked`` columns by name or index, or a bad one."""
    if valid:
        how = draw(st.sampled_from(["names", "indices", "mixed"]))
        return ",".join(
            names[i] if how == "names" or (how == "mixed" and i % 2) else str(i) for i in picked
        )
    return draw(
        st.sampled_from(
            [
                "",
                ",",
                "x1,,x2",
                "nope",
                "99",
                "-1",
                "x1,x1",
                "0,0",
                "1.5",
                " ",
                "x1;x2",
                "0,1,2,3,4,5,6,7",
            ]
        )
    )


OPTION_VALUES = {
    "--norm": (["sq", "group", "l1"], ["L2", "", "l0", "SQ"]),
    "--order": (["1", "2", "3"], ["0", "-1", "1.5", "two", ""]),
    "--lam": (
        ["auto", "1", "10.5", "0.1", "AUTO", "1e3"],
        ["-1", "nan", "inf", "x", "1e400", "", "0x10"],
    ),
    "--max-iter": (["50", "200"], ["0", "-5", "1.5", "many"]),
    "--tol": (["1e-6", "1e-3"], ["0", "-1", "nan", "inf", "tiny"]),
    "--n-changes": (["0", "1", "2"], ["-1", "1.5", "many", "1000000"]),
    "--penalty": (["bic", "aic", "5", "0", "BIC"], ["-1", "nan", "inf", "hq", ""]),
    "--min-size": (["3", "5", "8"], ["0", "-1", "2.5", "1000"]),
    "--na": (["1", "2", "3"], ["0", "-1", "1.5", "1000"]),
    "--fs": (["1", "16000", "0.5"], ["0", "-1", "nan", "inf", "fast"]),
    "--method": (["ml", "gcv", "lcurve", "cv", "bic", "aic"], ["ML", "", "best", "None"]),
}
FLAGS = {
    "fit": ["--refine", "--constant", "--json"],
    "segments": ["--constant", "--json"],
    "ar": ["--constant", "--json"],
    "select-lambda": ["--constant", "--json"],
    "simulate": ["--json"],
    "predict": ["--json"],
}
COMMAND_OPTIONS = {
    "fit": ["--norm", "--order", "--lam", "--max-iter", "--tol"],
    "segments": ["--n-changes", "--penalty", "--min-size"],
    "ar": ["--norm", "--order", "--lam", "--max-iter", "--tol", "--fs"],
    "select-lambda": ["--norm", "--order", "--method"],
    "simulate": [],
    "predict": [],
}


@dataclass(frozen=True)
class CliCase:
    """One command line: the argument list (with placeholders) and the files it needs."""

    argv: tuple
    csv: CsvFile
    model: ModelFile | str | None = None

    def __repr__(self) -> str:
        return f"CliCase(argv={list(self.argv)!r}, csv={self.csv!r}, model={self.model!r})"


@st.composite
def cli_cases(draw, *, valid: bool = False) -> CliCase:
    if not valid and draw(st.integers(0, 15)) == 0:  # no command, help, version, nonsense
        argv = draw(
            st.sampled_from(
                [
                    (),
                    ("--help",),
                    ("--version",),
                    ("fit", "--help"),
                    ("bogus",),
                    ("-h",),
                    ("fit",),
                    ("simulate", "@DATA"),
                    ("--", "fit"),
                    ("FIT", "@DATA"),
                ]
            )
        )
        return CliCase(tuple(argv), CsvFile(Data(10, 1, 0)), None)
    command = draw(
        st.sampled_from(
            ["fit", "fit", "segments", "ar", "select-lambda", "simulate", "predict", "demo"]
            if not valid
            else ["fit", "fit", "segments", "ar", "select-lambda", "simulate", "predict"]
        )
    )
    bad_budget = 0 if valid else draw(st.sampled_from([0, 0, 1, 1, 2]))
    if command in ("simulate", "predict"):
        model_kind = draw(st.sampled_from(["cli_fit", "cli_fit", "cli_ar", "cli_fit_constant"]))
        if not valid and draw(st.booleans()):
            model = draw(model_files())
        else:
            model = model_kind
        T = 31 if model_kind != "cli_ar" else 32
        csv = draw(
            csv_files(
                T=draw(st.sampled_from([T, T, T, T - 1, 5])) if not valid else T,
                n=2 if model_kind != "cli_ar" else 1,
                m=1 if model_kind != "cli_ar" else 0,
            )
        )
        if valid:
            csv = CsvFile(csv.data, "plain", csv.seed)
    else:
        model = None
        csv = draw(csv_files())
        if valid:
            csv = CsvFile(
                Data(csv.data.T, csv.data.n, csv.data.m, csv.data.seed), "plain", csv.seed
            )
    names = csv.names
    n, m = csv.data.n, csv.data.m
    args: list[str] = [command]
    if command == "demo":
        # only option combinations that must be rejected before any work
        system = draw(st.sampled_from(["robot", "chirp", "jump-linear", "rl", "bogus"]))
        args += [
            system,
            *draw(
                st.sampled_from(
                    [
                        ["--quick", "--full"],
                        ["--norm", "sq"],
                        ["--lam", "1"],
                        ["--seed", "-1"],
                        ["--bogus-option"],
                    ]
                )
            ),
        ]
        if system == "jump-linear":
            args += ["--quick"]
        return CliCase(tuple(args), csv, None)
    if command in ("simulate", "predict"):
        args.append("@MODEL")
    data_arg = (
        draw(st.sampled_from(["@DATA"] * 8 + ["-", "@MISSING", "@DIR"])) if not valid else "@DATA"
    )
    args.append(data_arg)

    def bad() -> bool:
        nonlocal bad_budget
        if bad_budget and draw(st.booleans()):
            bad_budget -= 1
            return True
        return False

    if command in ("fit", "segments") or (command == "select-lambda" and draw(st.booleans())):
        args += ["--state", _columns(draw, names, list(range(n)), valid=not bad())]
        if m and draw(st.booleans()):
            args += ["--input", _columns(draw, names, list(range(n, n + m)), valid=not bad())]
    elif command in ("ar", "select-lambda"):
        args += [
            "--column",
            draw(st.sampled_from([names[0], "0"]))
            if not bad()
            else draw(st.sampled_from(["", "zz", "99", "x1,x1"])),
        ]
        na = draw(st.sampled_from(OPTION_VALUES["--na"][1 if bad() else 0]))
        args += ["--na", na]
    elif command in ("simulate", "predict") and draw(st.booleans()):
        args += ["--state", _columns(draw, names, list(range(n)), valid=not bad())]
        if m:
            args += ["--input", names[n]]
    for option in COMMAND_OPTIONS[command]:
        if draw(st.integers(0, 2)) == 0:
            continue
        if command == "segments" and option == "--penalty" and "--n-changes" in args:
            continue
        if command == "select-lambda" and option == "--method":
            norm = args[args.index("--norm") + 1] if "--norm" in args else "sq"
            good = {
                "sq": ["ml", "gcv", "lcurve", "cv"],
                "group": ["lcurve", "cv"],
                "l1": ["lcurve", "cv"],
                "l0": ["bic", "aic"],
            }.get(norm, ["ml"])
            args += [option, draw(st.sampled_from(OPTION_VALUES[option][1] if bad() else good))]
            continue
        if command == "select-lambda" and option == "--norm":
            args += [option, draw(st.sampled_from(["sq", "group", "l1", "l0"]))]
            continue
        values = OPTION_VALUES[option][1 if bad() else 0]
        args += [option, draw(st.sampled_from(values))]
    for flag in FLAGS[command]:
        if draw(st.integers(0, 3)) == 0:
            args.append(flag)
    if command in ("fit", "segments", "ar", "simulate", "predict") and draw(st.integers(0, 3)) == 0:
        target = draw(
            st.sampled_from(
                ["@OUT.npz", "@OUT.npz", "@OUT.csv", "@NODIR/x.npz", "@DIR"]
                if not bad()
                else ["@NODIR/x.npz", "@DIR", ""]
            )
        )
        if command in ("simulate", "predict") and target == "@OUT.npz":
            target = "@OUT.csv"
        args += ["--out", target]
    if draw(st.integers(0, 23)) == 0:
        args += [
            "--plot",
            draw(st.sampled_from(["@OUT.png", "@OUT.png", "@OUT.xyz", "@NODIR/p.png"])),
        ]
    if bad():
        args.insert(
            draw(st.integers(1, len(args))),
            draw(st.sampled_from(["--bogus", "--lam", "-x", "--state", "--", "extra"])),
        )
    return CliCase(tuple(args), csv, model)


# ---------------------------------------------------------------------------- running

_MODEL_CACHE: dict[str, bytes] = {}


def _cli_model(kind: str) -> bytes:
    """Bytes of a model file written by the command line itself (cached)."""
    if kind not in _MODEL_CACHE:
        with tmpdir() as d:
            data = Data(
                31 if kind != "cli_ar" else 32,
                2 if kind != "cli_ar" else 1,
                1 if kind != "cli_ar" else 0,
                seed=5,
            )
            csv = os.path.join(d, "train.csv")
            with open(csv, "wb") as fh:
                fh.write(CsvFile(data).content())
            out = os.path.join(d, "m.npz")
            if kind == "cli_ar":
                argv = ["ar", csv, "--column", "x1", "--na", "1", "--lam", "5", "--out", out]
            else:
                argv = [
                    "fit",
                    csv,
                    "--state",
                    "x1,x2",
                    "--input",
                    "u1",
                    "--lam",
                    "5",
                    "--out",
                    out,
                ] + (["--constant"] if kind == "cli_fit_constant" else [])
            with (
                contextlib.redirect_stdout(io.StringIO()),
                contextlib.redirect_stderr(io.StringIO()),
            ):
                rc = _main()(argv)
            assert rc == 0, f"could not write the {kind} model"
            with open(out, "rb") as fh:
                _MODEL_CACHE[kind] = fh.read()
    return _MODEL_CACHE[kind]


def _main():
    from ltvmodels.cli import main

    return main


# A printed non-finite number stands alone: never inside a word, a name or another number.
NONFINITE_TOKEN = re.compile(
    r"(?<![A-Za-z0-9_])(nan|inf|-inf|infinity)(?![A-Za-z0-9_])", re.IGNORECASE
)


def nonfinite_line(stdout: str, directory: str) -> str | None:
    """The first line of a text report that prints a non-finite number, or None.

    The case's temporary ``directory`` is masked first: the report echoes the
    paths it read, and a random directory name may contain "inf" or "nan"
    (``ltvfuzz-epk1inf4`` once failed a run), and so may TMPDIR. Lines about an
    infinite λ are documented results, not failures."""
    for line in stdout.replace(directory, "<tmp>").splitlines():
        if (
            NONFINITE_TOKEN.search(line)
            and "lam=inf" not in line.replace(" ", "")
            and "lambda = inf" not in line
        ):
            return line
    return None


def check_cli(case: CliCase) -> None:
    """Run ``main(argv)`` for the case in a temporary directory and judge the outcome."""
    main = _main()
    label = f"cli {case.argv[0] if case.argv else '(none)'}"
    with tmpdir() as d:
        data_path = os.path.join(d, "data.csv")
        content = case.csv.content()
        with open(data_path, "wb") as fh:
            fh.write(content)
        model_path = os.path.join(d, "model.npz")
        if case.model is not None:
            with open(model_path, "wb") as fh:
                fh.write(
                    case.model.content()
                    if isinstance(case.model, ModelFile)
                    else _cli_model(case.model)
                )
        os.mkdir(os.path.join(d, "adir"))
        subst = {
            "@DATA": data_path,
            "@MODEL": model_path,
            "@MISSING": os.path.join(d, "missing.csv"),
            "@DIR": os.path.join(d, "adir"),
            "@OUT.npz": os.path.join(d, "out.npz"),
            "@OUT.csv": os.path.join(d, "out.csv"),
            "@OUT.png": os.path.join(d, "out.png"),
            "@OUT.xyz": os.path.join(d, "out.xyz"),
            "@NODIR/x.npz": os.path.join(d, "no", "x.npz"),
            "@NODIR/p.png": os.path.join(d, "no", "p.png"),
        }
        argv = [subst.get(a, a) for a in case.argv]
        out, err = io.StringIO(), io.StringIO()
        stdin = io.StringIO(content.decode("utf-8", errors="replace"))  # for DATA "-"
        old_stdin, old_cwd = sys.stdin, os.getcwd()
        started = time.perf_counter()
        os.chdir(d)  # anything written by default lands in the temporary directory
        try:
            sys.stdin = stdin
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    rc = main(argv)
                except SystemExit as exc:
                    rc = exc.code
                except BaseException as exc:  # noqa: BLE001
                    raise FuzzFailure(
                        label,
                        f"exception {type(exc).__name__} escaped main()",
                        f"{str(exc)[:150]}",
                        " ".join(case.argv),
                    ) from exc
        finally:
            sys.stdin = old_stdin
            os.chdir(old_cwd)
        stdout, stderr = out.getvalue(), err.getvalue()
        shown = " ".join(case.argv)
        if os.environ.get("FUZZ_LOG"):
            with open(os.environ["FUZZ_LOG"], "a", encoding="utf-8") as fh:
                fh.write(
                    f"{label}\trc={rc} {time.perf_counter() - started:.2f}s\t{shown}\t"
                    f"{stderr.strip()[:200]}\t{case.csv!r}\n"
                )

        def fail(kind: str, detail: str) -> None:
            raise FuzzFailure(label, kind, detail, shown)

        if "Traceback" in stdout + stderr:
            fail("traceback printed", stderr[-300:])
        for line in stderr.splitlines():
            if "warning:" in line and re.search(
                r"warning: (RuntimeWarning|UserWarning|"
                r"FutureWarning|DeprecationWarning|"
                r"NumbaWarning|LinAlgWarning)",
                line,
            ):
                fail("foreign warning reported", line[:200])
        if rc in (1, 2):
            errors = [line for line in stderr.splitlines() if "error:" in line]
            if len(errors) != 1:
                fail(f"exit {rc} without exactly one error line", stderr[-300:] or "(empty)")
            wrapped = "model file" in errors[0]  # load's documented catch-all
            if not wrapped and re.search(
                r"(IndexError|KeyError|AttributeError|ZeroDivisionError|"
                r"OverflowError|LinAlgError|BadZipFile|JSONDecodeError|"
                r"UnboundLocalError|NameError)",
                errors[0],
            ):
                fail("internal exception shown as a user error", errors[0][:200])
            for fragment in (
                "setting an array element",
                "could not broadcast",
                "index out of bounds",
                "unsupported operand",
                "'NoneType'",
                "object of type",
                "division by zero",
                "did not converge",
            ):
                if fragment in errors[0] and not wrapped:
                    fail("internal message shown as a user error", errors[0][:200])
            lam_at = argv.index("--lam") + 1 if "--lam" in argv else None
            auto = (
                bool(case.argv)
                and case.argv[0] in ("fit", "ar")
                and (
                    lam_at is None
                    or (lam_at < len(argv) and argv[lam_at].strip().lower() == "auto")
                )
            )
            if auto and "lam is too large" in errors[0]:
                fail("the λ chosen by --lam auto is rejected by the fit", errors[0][:200])
            OUTCOMES[(label, "library error")] += 1
            return
        if rc != 0:
            fail(f"exit status {rc!r}", stderr[-300:])
        other = [line for line in stderr.splitlines() if line.strip() and "warning:" not in line]
        if other:
            fail("unexpected stderr output on success", other[0][:200])
        divergence = "DivergenceWarning" in stderr
        if {"--help", "-h", "--version"} & set(argv):
            if not stdout.strip():
                fail("no help/version text", "(empty stdout)")
        elif "--json" in argv:
            try:
                report = strict_json(stdout)
            except ValueError as exc:
                fail("invalid JSON report", f"{exc}: {stdout[:200]}")
            _check_json_numbers(report, fail, divergence)
        else:
            if not stdout.strip():
                fail("no report on success", "(empty stdout)")
            line = None if divergence else nonfinite_line(stdout, d)
            if line is not None:
                fail("non-finite number in the report", line.strip()[:200])
        if "--out" in argv:
            target = argv[argv.index("--out") + 1]
            if not os.path.isfile(target):
                fail("--out not written", target)
            if target.endswith(".npz"):
                check_call(ltv.load, target, label="load (CLI --out)")
        OUTCOMES[(label, "finite")] += 1


def _check_json_numbers(value, fail, divergence: bool, where: str = "") -> None:
    """Every number finite (strict JSON already excludes NaN); null is a missing value."""
    if isinstance(value, dict):
        for key, item in value.items():
            _check_json_numbers(item, fail, divergence, f"{where}.{key}")
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_json_numbers(item, fail, divergence, f"{where}[{i}]")
    elif isinstance(value, float) and not np.isfinite(value):
        fail("non-finite number in the JSON report", where)


HUGE_CSV = CsvFile(Data(30, 2, 1, seed=1, scale=1e300))
SMALL_CSV = CsvFile(Data(8, 2, 1, seed=1))
EXPLICIT_CASES = [
    (CliCase(("fit", "@DATA", "--state", "x1,x2", "--input", "u1"), HUGE_CSV),),
    (CliCase(("select-lambda", "@DATA", "--state", "x1,x2", "--input", "u1"), HUGE_CSV),),
    (
        CliCase(
            ("segments", "@DATA", "--state", "x1,x2", "--input", "u1", "--penalty", "0"), SMALL_CSV
        ),
    ),
    (
        CliCase(
            (
                "fit",
                "@DATA",
                "--state",
                "x1,x2",
                "--input",
                "u1",
                "--norm",
                "group",
                "--lam",
                "1",
                "--json",
            ),
            CsvFile(Data(30, 2, 1, seed=1)),
        ),
    ),
    (
        CliCase(
            ("ar", "@DATA", "--column", "x1", "--na", "2", "--lam", "1"),
            CsvFile(Data(30, 1, 0, seed=1, scale=1e300)),
        ),
    ),
]


@fuzz_test(cli_cases(), examples=2.0, valid=(cli_cases(valid=True),), explicit=EXPLICIT_CASES)
def test_cli(case):
    """ltvmodels.cli.main(argv) with fuzzed commands, options, CSV and model files."""
    check_cli(case)


def test_cli_json_nulls_are_documented():
    """Sanity check of the oracle itself: strict JSON rejects NaN, accepts null."""
    assert strict_json('{"a": null}') == {"a": None}
    try:
        strict_json('{"a": NaN}')
    except ValueError:
        return
    raise AssertionError("strict_json accepted NaN")


def test_nonfinite_numbers_are_found_in_reports_but_not_in_their_paths():
    """Sanity check of the oracle itself: a non-finite number in a report fails it; the
    temporary directory's name, names with digits and an infinite λ do not."""
    directory = "/tmp/inf/ltvfuzz-epk1inf4"  # a TMPDIR named "inf", and a random name
    for line in ("k = nan", "sigma2 [1.0, -inf]", "objective: inf", "gap Infinity"):
        assert nonfinite_line(f"header\n{line}\n", directory) == line
    clean = (
        f"ltvmodels segments: {directory}/data.csv, T = 8 samples; states x1, x2\n"
        "column v2nan3: fitted\nlam=inf (constant coefficients)\n"
    )
    assert nonfinite_line(clean, directory) is None
    # the directory is masked only where it appears, not every "inf"
    assert nonfinite_line(f"{directory}/data.csv: inf\n", directory) is not None
