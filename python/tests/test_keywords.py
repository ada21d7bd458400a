"""Option errors name the keyword and the values it takes (never a JSON parser's position, a
serde enum or a CLI flag), and complex input is a TypeError, not a silently dropped imaginary
part. Each case failed on the code before (serde's "expected value at line 1 column 10",
"--max-rows", "--criterion", complex OP read as its real part)."""

import numpy as np
import pytest

import stiction


@pytest.fixture(scope="module")
def df():
    return stiction.simulate(valve={"kind": "kano", "S": 4.0, "J": 1.0}, samples=600, seed=2)


@pytest.mark.parametrize(
    "options, words",
    [
        ({"step": float("nan")}, ["step=nan", "finite number > 0"]),
        ({"step": float("inf")}, ["step=inf", "finite number > 0"]),
        ({"criterion": "bogus"}, ["criterion='bogus'", "'prediction', 'simulation'"]),
        ({"init": "In.9"}, ["init='In.9'", "'In.1', 'In.2', 'In.3'"]),
        ({"split": 2}, ["split=2", "< 1"]),
        ({"delay": "x"}, ["delay='x'", '"auto"']),
        ({"delay": -1}, ["delay=-1", ">= 0"]),
        ({"max_nodes": 0}, ["max_nodes=0", ">= 1"]),
        ({"max_rows": "x"}, ["max_rows='x'", ">= 1"]),
        ({"gaps": "fill"}, ["gaps='fill'", "'refuse', 'hold', 'drop'"]),
        ({"op_range": (0, float("nan"))}, ["op_range=", "lo < hi"]),
    ],
)
def test_option_errors_name_the_keyword_and_its_values(df, options, words):
    with pytest.raises(stiction.UsageError) as e:
        stiction.quantify(df, **options)
    message = str(e.value)
    for w in words:
        assert w in message, message
    for leak in ("line 1 column", "untagged enum", "--"):
        assert leak not in message, message


def test_library_messages_name_keywords_not_flags(df):
    with pytest.raises(stiction.DataError) as e:
        stiction.quantify(df, max_rows=10)
    assert "max_rows" in str(e.value) and "--max-rows" not in str(e.value)
    with pytest.raises(stiction.DataError) as e:
        stiction.quantify(df, op_range=(0, 10))
    assert "op_range" in str(e.value) and "--op-range" not in str(e.value)


def test_complex_input_is_a_type_error(df):
    with pytest.raises(TypeError, match="complex"):
        stiction.valve(df["OP"].to_numpy() + 1j, "kano", {"S": 1.0})
    frame = df.copy()
    frame["OP"] = frame["OP"].astype(complex)
    with pytest.raises(TypeError, match="column 'OP': complex"):
        stiction.quantify(frame)
    with pytest.raises(TypeError, match="complex"):
        stiction.detect({"OP": df["OP"].to_numpy() + 0j, "PV": df["PV"].to_numpy()})
