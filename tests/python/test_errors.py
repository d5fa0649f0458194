"""The library's errors as Python exceptions, with the command line's messages."""
import pytest

import ieslam
from conftest import cli


def test_exception_classes():
    assert issubclass(ieslam.ConfigError, ValueError)
    assert issubclass(ieslam.DataError, Exception)
    assert not issubclass(ieslam.DataError, ValueError)


@pytest.mark.parametrize("options, overrides, named", [
    ({"selector": {"bufer": 3}}, {}, "selector.bufer"),
    ({"no_such_section": {"x": 1}}, {}, "no_such_section"),
    ({"thread": 1}, {}, "thread"),
    ({"selector.kind": "best"}, {}, "selector.kind"),
    (None, {"bogus": 1}, "bogus"),
    (None, {"buffer": "four"}, "selector.buffer"),
    (None, {"buffer": 0}, "selector.buffer"),
    (None, {"selector": "best"}, "selector.kind"),
    ({"features": {"max_features": [1]}}, {}, "features.max_features"),
])
def test_bad_options_raise_config_error_naming_the_key(seven_scenes, options, overrides, named):
    with pytest.raises(ieslam.ConfigError, match=named.replace(".", r"\.")):
        ieslam.run(seven_scenes, options, **overrides)


def test_missing_config_file(tmp_path, seven_scenes):
    with pytest.raises(ieslam.ConfigError, match="missing.yaml"):
        ieslam.run(seven_scenes, str(tmp_path / "missing.yaml"))


def test_missing_dataset_raises_data_error_with_the_cli_message(tmp_path):
    missing = tmp_path / "no_such_dataset"
    with pytest.raises(ieslam.DataError) as error:
        ieslam.run(str(missing))
    assert str(missing) in str(error.value)
    process = cli("run", "--dataset", missing, "--output", tmp_path / "out", check=False)
    assert process.returncode == 3
    assert str(error.value) in process.stderr
    with pytest.raises(ieslam.DataError):
        ieslam.load_dataset(str(missing))


def test_unwritable_output(runs, tmp_path):
    result = runs[0]
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.raises((ieslam.ConfigError, ieslam.OutputError)):
        result.write(str(blocker / "out"))
