"""A file's SHA-256 read in blocks is hashlib's of its whole bytes, across a block boundary."""

import hashlib

import pytest

from symgrasp.digest import file_sha256


@pytest.mark.parametrize("size", [0, 1, (1 << 20) - 1, 1 << 20, (1 << 20) + 1, 3 << 20])
def test_the_blocks_hash_to_the_whole_files_digest(size, tmp_path):
    data = bytes(range(256)) * (size // 256) + bytes(size % 256)
    path = tmp_path / "f.bin"
    path.write_bytes(data)
    assert file_sha256(path) == file_sha256(str(path)) == hashlib.sha256(data).hexdigest()
