"""A base model bundle and a drive file, shared by the serving tests."""

import pytest

from support.serving import base_bundle, write_drive


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    return base_bundle(tmp_path_factory.mktemp("bundle"))


@pytest.fixture(scope="module")
def drive_csv(tmp_path_factory):
    return write_drive(tmp_path_factory.mktemp("drive") / "V-Wavy.csv")
