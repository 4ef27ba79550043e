"""Logs as real loggers write them (device.toml ``[log]``): CSV in any dialect, TDMS, Parquet.

A log written in any layout reads back as the same log (to the bit where the units'
conversion is exact: the same numbers in s, rad and N m; else within an ulp or two, or the
time stamps' rounding to whole us or ns); every fault of a layout is one line naming the
file, the line, row or channel, and the ``[log]`` key that fixes it; the default layout reads
the two headers of older rsp-inertia; and an experiment identified from its logs in any
layout gives the plain CSV's tensor.
"""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rsp_inertia.api import identify
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Encoder, LogLayout, load_device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.log_files import EPOCH, TEMPERATURE
from rsp_inertia.plant.logs import Log, read_device_log, read_log, write_log
from tests.conftest import copy_experiment

ENCODER = Encoder(counts_per_rev=65536, sample_rate=1000.0, counter_bits=32)
Q = ENCODER.quantum
TORQUE_CONSTANT = 0.05
"""N m/A, the drive's torque constant of the current-logging layouts."""


def a_log(n: int = 2000, temperature: bool = True) -> Log:
    """A braking-like log on the encoder grid, jittered stamps, a noisy torque, a warming
    motor."""
    rng = np.random.default_rng(7)
    t = (np.arange(n) + rng.uniform(-0.2, 0.2, n)) / ENCODER.sample_rate
    t[0] = 0.0
    phi = np.floor(np.cumsum(np.linspace(0.012, 0.0, n)) / Q) * Q
    torque = -0.005 + 1e-4 * rng.standard_normal(n)
    heat = np.linspace(24.8, 25.3, n) if temperature else None
    return Log(t=t, phi=phi, torque=torque, temperature=heat)


LAYOUTS = {
    # name: (layout, exact: t, phi and torque read back bit for bit)
    "plain CSV": (LogLayout(), True),
    "semicolon, decimal comma, units row, named columns, ms, deg, mN m": (
        LogLayout(
            delimiter=";",
            decimal=",",
            skip_after_header=1,
            time_column="Time [ms]",
            time_unit="ms",
            angle_column="Angle [deg]",
            angle_unit="deg",
            torque_column="Torque [mN m]",
            torque_unit="mN m",
            temperature_column="Motor temperature [C]",
        ),
        False,
    ),
    "tab, header on line 3, counts, epoch ns": (
        LogLayout(
            delimiter="\t", header_line=3, angle_unit="counts", time_unit="ns", time_origin="first"
        ),
        False,
    ),
    "blanks, us": (LogLayout(delimiter=" ", time_unit="us"), False),
    "current in A": (LogLayout(torque_unit="A", temperature_column="T"), False),
    "TDMS with a time channel": (LogLayout(format="tdms", tdms_group="Drive"), True),
    "TDMS with epoch timestamps": (
        LogLayout(format="tdms", time_origin="first", temperature_column="T"), False
    ),
    "Parquet": (LogLayout(format="parquet", temperature_column="T"), True),
    "Parquet with epoch timestamps and counts": (
        LogLayout(format="parquet", time_origin="first", angle_unit="counts"), False
    ),
}


@pytest.mark.parametrize("name", LAYOUTS)
def test_a_log_reads_back_as_written_in_every_layout(tmp_path, name):
    layout, exact = LAYOUTS[name]
    log = a_log()
    path = tmp_path / f"braking{layout.extension}"
    write_log(path, log, layout=layout, encoder=ENCODER, torque_constant=TORQUE_CONSTANT)
    first = path.read_bytes()
    write_log(path, log, layout=layout, encoder=ENCODER, torque_constant=TORQUE_CONSTANT)
    assert path.read_bytes() == first  # deterministic: the same log, the same bytes
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # atomic: no temporaries left
    back = read_log(path, ENCODER, "braking", layout=layout, torque_constant=TORQUE_CONSTANT)
    # The angle is on the encoder grid in every unit: the same numbers, bit for bit.
    np.testing.assert_array_equal(back.phi, log.phi)
    if exact:
        np.testing.assert_array_equal(back.t, log.t)
        np.testing.assert_array_equal(back.torque, log.torque)
    else:
        # stamps rounded to whole us (TDMS dates, whose 2^-64 s fractions lose a ns more), a
        # unit's scale within an ulp or two
        np.testing.assert_allclose(back.t, log.t, rtol=0, atol=0.5e-6 + 2e-9)
        np.testing.assert_allclose(back.torque, log.torque, rtol=4e-16, atol=0)
    if layout.temperature_column:
        np.testing.assert_array_equal(back.temperature, log.temperature)
    else:
        assert back.temperature is None


def test_epoch_time_stamps_are_subtracted_exactly(tmp_path):
    """ns since 1970 exceed float64's 53 bits; subtracted as integers, a 1 ns step stays one."""
    path = tmp_path / "pilot.csv"
    stamps = EPOCH * 10**9 + np.array([0, 1_000_001, 2_000_000, 3_000_001])
    rows = "".join(f"{s},{k * Q!r},0.0\n" for k, s in enumerate(stamps))
    path.write_text("t,phi,torque\n" + rows)
    layout = LogLayout(time_unit="ns", time_origin="first")
    back = read_log(path, ENCODER, "pilot", layout=layout)
    np.testing.assert_array_equal(back.t, np.array([0, 1_000_001, 2_000_000, 3_000_001]) / 1e9)


def test_the_default_layout_reads_both_headers_of_older_logs(tmp_path):
    log = a_log(temperature=False)
    plain, counts = tmp_path / "phi.csv", tmp_path / "counts.csv"
    write_log(plain, log)
    write_log(counts, log, counter=ENCODER)
    assert plain.read_text().startswith("t,phi,torque\n")
    assert counts.read_text().startswith("t,counts,torque\n")
    for path in (plain, counts):
        back = read_log(path, ENCODER, "braking")
        for name in ("t", "phi", "torque"):
            np.testing.assert_array_equal(getattr(back, name), getattr(log, name))


def test_a_held_braking_is_cut_with_its_temperature(tmp_path):
    log = a_log()
    n = len(log)
    held = Log(
        t=np.concatenate([log.t, log.t[-1] + np.arange(1, 401) / ENCODER.sample_rate]),
        phi=np.concatenate([log.phi, np.full(400, log.phi[-1])]),
        torque=np.concatenate([log.torque, np.zeros(400)]),
        temperature=np.concatenate([log.temperature, np.full(400, 30.0)]),
    )
    layout = LogLayout(format="parquet", temperature_column="T")
    path = tmp_path / "braking.parquet"
    write_log(path, held, layout=layout, encoder=ENCODER)
    back = read_log(path, ENCODER, "braking", layout=layout)
    assert len(back) < n + 1 and len(back.temperature) == len(back)
    assert back.notes and re.match(rf"{re.escape(str(path))}, rows \d+-{n + 400}:", back.notes[0])
    assert back.temperature.max() < 30.0


def test_a_waveform_tdms_holds_only_a_regular_log(tmp_path):
    layout = LogLayout(format="tdms", time_column="")
    regular = dataclasses.replace(a_log(), t=np.arange(2000) * 0.001)
    path = tmp_path / "braking.tdms"
    write_log(path, regular, layout=layout, encoder=ENCODER)
    back = read_log(path, ENCODER, "braking", layout=layout)
    np.testing.assert_array_equal(back.t, regular.t)
    with pytest.raises(ValueError, match="waveform timing"):
        write_log(path, a_log(), layout=layout, encoder=ENCODER)  # jittered stamps


# --- faults: one line naming the file, the line, row or channel, and the key ---------------


def _one_line(error: pytest.ExceptionInfo, *words: str) -> str:
    message = str(error.value)
    assert "\n" not in message
    for word in words:
        assert word in message, message
    return message


def test_a_column_not_found_names_the_header_and_the_key(tmp_path):
    path = tmp_path / "stage1" / "braking.csv"
    path.parent.mkdir()
    path.write_text("Time [ms],Angle [deg],Torque [mN m]\n0,0,0\n1,0,0\n")
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=LogLayout(time_column="Time [ms]"))
    assert str(error.value).startswith(f"{path}, line 1: column 'phi' not found")
    layout = LogLayout(time_column="Time [ms]", angle_column="Angle [deg]", angle_unit="deg")
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=layout)
    assert str(error.value) == (
        f"{path}, line 1: column 'torque' not found; the header has 'Time [ms]', "
        "'Angle [deg]', 'Torque [mN m]': set [log] torque_column"
    )


def test_a_header_split_at_another_delimiter_names_the_delimiter(tmp_path):
    path = tmp_path / "braking.csv"
    path.write_text("t;phi;torque\n0;0;0\n0.001;0;0\n")
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking")
    _one_line(error, f"{path}, line 1", "set [log] delimiter")


def test_a_units_row_not_skipped_names_its_line_and_the_key(tmp_path):
    path = tmp_path / "braking.csv"
    path.write_text("# logger v2\nt;phi;torque\ns;rad;N m\n0;0;0\n0,001;0;0\n")
    layout = LogLayout(delimiter=";", decimal=",", header_line=2)
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=layout)
    _one_line(error, f"{path}, line 3: t = 's' is not a number", "set [log] skip_after_header")
    # skipped, every line number is the file's own: line 5 holds the second data row
    path.write_text("# logger v2\nt;phi;torque\ns;rad;N m\n0;0;0\n0,0001;0;0\n")
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=dataclasses.replace(layout, skip_after_header=1))
    _one_line(error, f"{path}, line 5: time step")


def test_a_decimal_comma_not_declared_is_named(tmp_path):
    path = tmp_path / "braking.csv"
    path.write_text("t;phi;torque\n0;0;0\n0,001;0;0\n")
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=LogLayout(delimiter=";"))
    _one_line(error, f"{path}, line 3: t = '0,001' is not a number", "set [log] decimal")


def test_a_missing_log_names_the_file_of_another_format_beside_it(tmp_path):
    write_log(tmp_path / "braking.csv", a_log())
    with pytest.raises(InputError) as error:
        read_log(tmp_path / "braking.parquet", ENCODER, "braking", layout=LogLayout(format="parquet"))
    _one_line(error, "braking.parquet: no such file, but braking.csv is there", "[log] format")


def test_tdms_group_and_channel_not_found_are_named(tmp_path):
    path = tmp_path / "braking.tdms"
    write_log(path, a_log(), layout=LogLayout(format="tdms"), encoder=ENCODER)
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=LogLayout(format="tdms", tdms_group="Drive"))
    _one_line(error, f"{path}: group 'Drive' not found; the file has 'Log'", "[log] tdms_group")
    layout = LogLayout(format="tdms", torque_column="current", torque_unit="A")
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=layout, torque_constant=0.05)
    _one_line(error, "channel 'current' not found in group 'Log'", "[log] torque_column")


def test_a_parquet_column_not_found_is_named(tmp_path):
    path = tmp_path / "braking.parquet"
    write_log(path, a_log(), layout=LogLayout(format="parquet"), encoder=ENCODER)
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=LogLayout(format="parquet", temperature_column="T"))
    _one_line(error, f"{path}: column 'T' not found", "set [log] temperature_column")


def test_a_current_without_a_torque_constant_is_refused(tmp_path):
    path = tmp_path / "braking.csv"
    write_log(path, a_log())
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=LogLayout(torque_unit="A"))
    _one_line(error, "torque_unit = 'A'", "motor.torque_constant")


def test_faults_past_the_header_name_binary_rows(tmp_path):
    log = a_log(temperature=False)
    torque = log.torque.copy()
    torque[41:45] = 50.0  # beyond 10 x the torque limit, four rows (one alone is a glitch)
    path = tmp_path / "braking.parquet"
    write_log(path, dataclasses.replace(log, torque=torque), layout=LogLayout(format="parquet"),
              encoder=ENCODER)
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", layout=LogLayout(format="parquet"), torque_limit=0.5)
    _one_line(error, f"{path}, row 42: torque = 50.0 N m is beyond")


# --- device.toml [log] --------------------------------------------------------------------

DEVICE = Path(__file__).resolve().parents[2] / "plant" / "defaults" / "device.toml"

BAD_LAYOUTS = {
    # name: (text added to the default device.toml, the one line's end)
    "unknown format": (
        '[log]\nformat = "xlsx"\n',
        "log.format: must be one of 'csv', 'tdms', 'parquet', got 'xlsx'",
    ),
    "unknown time unit": (
        '[log]\ntime_unit = "min"\n', "log.time_unit: must be one of 's', 'ms', 'us', 'ns', got 'min'"
    ),
    "unknown torque unit": ('[log]\ntorque_unit = "Nm"\n', "log.torque_unit: must be one of"),
    "unknown delimiter": ('[log]\ndelimiter = "|"\n', "log.delimiter: must be one of"),
    "current without a torque constant": (
        '[log]\ntorque_unit = "A"\n',
        "log.torque_unit: 'A' (the motor current) needs motor.torque_constant (N m/A)",
    ),
    "decimal comma with a comma delimiter": (
        '[log]\ndecimal = ","\n', "log.decimal: ',' needs another delimiter than ','"
    ),
    "a CSV key in TDMS": ('[log]\nformat = "tdms"\nheader_line = 3\n',
                          "log.header_line: a CSV key, but log.format is 'tdms'"),
    "waveform timing in CSV": ('[log]\ntime_column = ""\n', "log.time_column: empty"),
    "a group in Parquet": ('[log]\nformat = "parquet"\ntdms_group = "x"\n', "log.tdms_group"),
}


@pytest.mark.parametrize("case", BAD_LAYOUTS)
def test_a_bad_log_table_is_one_line_naming_the_key(tmp_path, case):
    added, end = BAD_LAYOUTS[case]
    path = tmp_path / "device.toml"
    path.write_text(DEVICE.read_text() + "\n" + added)
    with pytest.raises(InputError) as error:
        load_device(path)
    message = _one_line(error, end)
    assert message.startswith(f"{path}: log.")


def test_a_torque_constant_without_a_current_is_refused(tmp_path):
    path = tmp_path / "device.toml"
    text = re.sub(r"(?m)^\[motor\].*$", "[motor]\ntorque_constant = 0.05", DEVICE.read_text())
    path.write_text(text)
    with pytest.raises(InputError) as error:
        load_device(path)
    _one_line(error, "motor.torque_constant: given, but log.torque_unit is 'N m'")


# --- experiments in every layout ---------------------------------------------------------

VARIANTS = {
    "a plain CSV": "",
    "b semicolon, decimal comma, units row, named columns": """
[log]
delimiter = ";"
decimal = ","
skip_after_header = 1
time_column = "Time [ms]"
time_unit = "ms"
angle_column = "Angle [deg]"
angle_unit = "deg"
torque_column = "Torque [mN m]"
torque_unit = "mN m"
temperature_column = "Motor temperature [C]"
""",
    "c tab, counts, epoch time": """
[log]
delimiter = "\\t"
angle_unit = "counts"
time_unit = "ns"
time_origin = "first"
""",
    "d current in A": """
[log]
torque_unit = "A"
""",
    "e TDMS with a time channel": """
[log]
format = "tdms"
tdms_group = "Drive log"
""",
    "f TDMS with waveform timing": """
[log]
format = "tdms"
time_column = ""
""",
    "g Parquet": """
[log]
format = "parquet"
""",
}


def in_layout(source: Path, root: Path, variant: str) -> Path:
    """A copy of the experiment ``source`` with its logs as a logger of ``variant`` writes
    them: each log read in the default layout and written in the variant's (the program
    stays program.csv)."""
    root = copy_experiment(source, root)
    plain = open_experiment(root)
    text = (root / "device.toml").read_text()
    if "torque_unit = \"A\"" in VARIANTS[variant]:
        text = re.sub(r"(?m)^\[motor\].*$", f"[motor]\ntorque_constant = {TORQUE_CONSTANT}", text)
    (root / "device.toml").write_text(text + VARIANTS[variant])
    exp = open_experiment(root)
    for stage, st in enumerate(exp.device.stages, 1):
        for direction in st.directions:
            for old, new, kind in (
                (plain.braking_path(stage, direction), exp.braking_path(stage, direction),
                 "braking"),
                (plain.reverse_path(stage, direction), exp.reverse_path(stage, direction),
                 "reverse"),
            ):
                log = read_device_log(old, plain.device, kind, direction)
                old.unlink()
                write_log(new, log, layout=exp.device.log, encoder=exp.device.encoder,
                          torque_constant=exp.device.motor.torque_constant)
    return root


def _identified(root: Path):
    return identify(root)


@pytest.fixture(scope="module")
def plain_result(default_logs, tmp_path_factory):
    """identify on the default experiment's plain CSV logs (about 5 s)."""
    return _identified(copy_experiment(default_logs, tmp_path_factory.mktemp("plain") / "exp"))


def _same_tensor(result, plain) -> float:
    """The largest difference of an entry from the plain CSV's, in its std."""
    std = np.sqrt(np.diag(plain.entries_cov))
    return float(np.max(np.abs(result.entries - plain.entries) / std))


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_every_layout_reads_the_same_logs(default_logs, tmp_path, variant):
    """Each layout's logs read back as the plain CSV's."""
    root = in_layout(default_logs, tmp_path / "exp", variant)
    exp, plain = open_experiment(root), open_experiment(default_logs)
    for stage in (1, 2):
        for kind in ("braking", "reverse"):
            where = exp.braking_path if kind == "braking" else exp.reverse_path
            old = plain.braking_path if kind == "braking" else plain.reverse_path
            back = read_device_log(where(stage), exp.device, kind)
            log = read_device_log(old(stage), plain.device, kind)
            np.testing.assert_array_equal(back.phi, log.phi)
            np.testing.assert_allclose(back.t, log.t, rtol=0, atol=1e-9)
            np.testing.assert_allclose(back.torque, log.torque, rtol=4e-16, atol=0)
            if "temperature" in VARIANTS[variant]:
                np.testing.assert_array_equal(back.temperature, TEMPERATURE)


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_identify_from_every_layout_gives_the_plain_csvs_tensor(
    default_logs, plain_result, tmp_path, variant
):
    """(a) to (g), each entry within 1e-3 of its std of the plain CSV's (about 1 s each once
    the session's first identify has built its model)."""
    result = _identified(in_layout(default_logs, tmp_path / "exp", variant))
    assert _same_tensor(result, plain_result) < 1e-3


def test_reading_a_csv_log_loads_pyarrows_csv_reader_but_not_nptdms(tmp_path):
    path = tmp_path / "braking.csv"
    write_log(path, a_log())
    code = (
        "import sys\n"
        "from rsp_inertia.plant.config import Encoder\n"
        "from rsp_inertia.plant.logs import read_log\n"
        f"read_log({str(path)!r}, Encoder(counts_per_rev=65536, sample_rate=1000.0), 'braking')\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'nptdms', 'pyarrow'}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "['pyarrow']"
    # Importing the readers loads neither.
    code = code.splitlines()
    code = "\n".join([*code[:3], code[-1]])
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize(
    "dialect, text",
    [
        (",", "t,phi,torque\n{rows}"),
        (";", "Zeit;Winkel;Moment\n[s];[rad];[N m]\n{rows}"),
        ("\t", "# logger v2\nt\tphi\ttorque\n{rows}"),
        (" ", "t phi torque\n{rows}"),
        (" ", "  t   phi\ttorque\n{rows}"),
    ],
)
def test_the_fast_csv_reader_reads_what_the_careful_one_reads(tmp_path, monkeypatch, dialect, text):
    """pyarrow's reader (log_checks._arrow_columns) and the numpy one give the same numbers
    to the bit, in any dialect, whatever the decimal digits (``float()`` of every field), the
    time stamps' integers exactly; and every file pyarrow cannot read as plain numbers goes
    to the careful reader, which names the line (the faults' tests)."""
    from rsp_inertia.plant import log_checks
    from rsp_inertia.plant.log_checks import CsvDialect, read_columns

    rng = np.random.default_rng(3)
    n = 3000
    t = np.cumsum(rng.integers(900, 1100, n))  # integer stamps (us)
    phi = rng.standard_normal(n) * 10.0 ** rng.integers(-8, 8, n)
    torque = [f"{v:.{d}g}" for v, d in zip(rng.standard_normal(n), rng.integers(1, 25, n))]
    comma = dialect == ";"
    fields = [
        [str(a), repr(float(b)), c] for a, b, c in zip(t.tolist(), phi.tolist(), torque)
    ]
    runs = "  " in text  # blanks and tabs of any run between the fields
    rows = "".join(
        (" \t " if runs and k % 7 == 0 else dialect).join(
            f.replace(".", ",") if comma else f for f in row
        ) + "\n"
        for k, row in enumerate(fields)
    )
    path = tmp_path / "log.csv"
    path.write_text(text.format(rows=rows))
    header = 2 if dialect == "\t" else 1
    csv = CsvDialect(
        delimiter=dialect,
        decimal="," if comma else ".",
        header_line=header,
        skip_after_header=1 if comma else 0,
    )
    names = ("Zeit", "Winkel", "Moment") if comma else ("t", "phi", "torque")
    keys = ("time_column", "angle_column", "torque_column")
    _arrow = log_checks._arrow_columns
    fast = read_columns(path, names, csv, keys, integer=0)
    called = []
    monkeypatch.setattr(log_checks, "_arrow_columns", lambda *a: called.append(a))
    careful = read_columns(path, names, csv, keys, integer=0)
    assert called  # the second read went the careful way
    # pyarrow read the first, but for runs of blanks, which it cannot split.
    assert (_arrow(path, [0, 1, 2], 3, csv, 0) is None) == runs
    assert np.array_equal(fast.values, careful.values)
    assert np.array_equal(fast.integers, careful.integers) and fast.integers.dtype == np.int64
    assert fast.rows == careful.rows
    assert np.array_equal(fast.values[:, 2], [float(v) for v in torque])
