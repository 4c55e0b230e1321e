"""``le.edit`` from Python checks a script against its linkage as the CLI does: the same
:class:`InputError`, never a KeyError or TypeError."""

from __future__ import annotations

import pytest

import linkedit as le
from linkedit.errors import InputError
from tests.conftest import EXAMPLES

SCRIPT = """\
samples: 40
lock: [O]
operations:
  - displace: {joint: Z, to: [-20, 36]}
"""


def test_an_unknown_joint_in_a_script_file_is_the_clis_input_error(run_cli, tmp_path):
    script = tmp_path / "s.yaml"
    script.write_text(SCRIPT)
    r = run_cli("edit", EXAMPLES / "jansen.yaml", script, "-o", tmp_path / "out")
    assert r.exit_code == 2
    with pytest.raises(InputError) as caught:
        le.edit(EXAMPLES / "jansen.yaml", script)
    assert f"linkedit: error: {caught.value}" == r.output.strip()
    assert caught.value.line == 4 and "unknown joint 'Z'" in str(caught.value)


def test_an_unknown_joint_in_a_dict_script_is_an_input_error():
    with pytest.raises(InputError, match=r"operations\[0\]\.displace\.joint: unknown joint 'Z'"):
        le.edit(EXAMPLES / "jansen.yaml", {"operations": [{"displace": {"joint": "Z", "to": [0, 0]}}]})


def test_a_malformed_dict_script_is_an_input_error():
    with pytest.raises(InputError, match=r"operations\[0\]\.displace"):
        le.edit(EXAMPLES / "jansen.yaml", {"operations": [{"displace": {"joint": "C"}}]})


def test_an_unknown_joint_in_a_script_object_is_an_input_error():
    from linkedit.spec.edit_script import EditScript

    script = EditScript.model_validate({"operations": [{"displace": {"joint": "Z", "to": [0, 0]}}]})
    with pytest.raises(InputError, match="unknown joint 'Z'"):
        le.edit(EXAMPLES / "jansen.yaml", script)
