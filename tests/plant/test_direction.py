"""The direction of a run: parsed once where it enters, a sign inside, its word outside."""

import json

import pytest

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.direction import Direction


def test_the_sign_is_that_of_the_braking_speed():
    assert [direction.sign for direction in Direction] == [1, -1]
    assert all(Direction.of_sign(direction.sign) is direction for direction in Direction)
    assert Direction.of_sign(2.5) is Direction.FORWARD
    assert Direction.of_sign(-0.1) is Direction.BACKWARD


def test_a_direction_reads_as_its_word_in_text_and_files():
    backward = Direction.BACKWARD
    assert f"{backward}" == str(backward) == "backward" == backward
    assert repr(backward) == "'backward'"  # messages that quote a direction read as before
    assert json.dumps({"direction": backward}) == '{"direction": "backward"}'
    assert {(1, "backward"): 0}[1, backward] == 0  # a key of (stage, word) finds it


@pytest.mark.parametrize("text", ["forward", "backward"])
def test_parse_gives_the_member(text):
    assert Direction.parse(text, "--direction") is Direction(text)


@pytest.mark.parametrize("text", ["up", "Forward", "", 1])
def test_parse_refuses_other_words_naming_the_key(text):
    with pytest.raises(InputError) as error:
        Direction.parse(text, "--direction")
    assert str(error.value) == f"--direction: must be one of forward, backward, got {text!r}"
