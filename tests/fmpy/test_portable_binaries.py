"""The shipped Linux libraries load on glibc 2.17 and newer, and are stripped.

A small ELF reader (no binutils needed): the glibc versions a library requires are the
`GLIBC_x.y` names of its version-needs section (SHT_GNU_verneed, ELF gABI and the LSB's symbol
versioning chapter); a stripped library has no SHT_SYMTAB section (.dynsym stays, it is what
the loader uses)."""

import re
import struct
import zipfile

import pytest

import fmu_support as support

SHT_SYMTAB = 2
SHT_GNU_VERNEED = 0x6FFFFFFE
MAX_GLIBC = (2, 17)


def sections(image):
    """(type, offset, size, link) of every section of a little-endian ELF64 image."""
    assert image[:4] == b"\x7fELF" and image[4] == 2 and image[5] == 1, "not a little-endian ELF64"
    (shoff,) = struct.unpack_from("<Q", image, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", image, 0x3A)
    result = []
    for index in range(shnum):
        base = shoff + index * shentsize
        _, kind, _, _, offset, size, link = struct.unpack_from("<IIQQQQI", image, base)
        result.append((kind, offset, size, link))
    return result


def needed_versions(image):
    """The version names (e.g. GLIBC_2.14) of the SHT_GNU_verneed section."""
    table = sections(image)
    names = set()
    for kind, offset, _, link in table:
        if kind != SHT_GNU_VERNEED:
            continue
        strings = table[link][1]
        need = offset
        while True:
            _, count, _, aux, next_need = struct.unpack_from("<HHIII", image, need)
            entry = need + aux
            for _ in range(count):
                _, _, _, name, next_aux = struct.unpack_from("<IHHII", image, entry)
                end = image.index(b"\0", strings + name)
                names.add(image[strings + name:end].decode())
                entry += next_aux
            if next_need == 0:
                break
            need += next_need
    return names


def glibc_versions(image):
    return sorted(tuple(int(part) for part in match.groups())
                  for name in needed_versions(image)
                  if (match := re.fullmatch(r"GLIBC_(\d+)\.(\d+)(?:\.\d+)?", name)))


@pytest.mark.parametrize("which", [support.VEHICLE, support.ESTIMATOR])
def test_the_linux_library_needs_at_most_glibc_2_17_and_is_stripped(which):
    archive = support.archive_path(f"{which}.fmu")
    with zipfile.ZipFile(archive) as fmu:
        image = fmu.read(f"binaries/linux64/{which}.so")
    versions = glibc_versions(image)
    assert versions, "no GLIBC symbol versions found: the reader or the library is wrong"
    newest = versions[-1]
    assert newest <= MAX_GLIBC, (
        f"{which}.so needs GLIBC_{newest[0]}.{newest[1]} (> 2.17): it will not load on RHEL 8, "
        f"Ubuntu 20.04 or Debian 11; package with cargo zigbuild (the default of packaging)")
    assert not any(kind == SHT_SYMTAB for kind, *_ in sections(image)), f"{which}.so is not stripped"


def test_the_reader_sees_a_newer_glibc_in_a_host_library():
    """The check can fail: the Python interpreter's own binary needs more than glibc 2.17 on
    any machine of the last years (it links memcpy@GLIBC_2.14 at least)."""
    import sys
    with open(sys.executable, "rb") as executable:
        image = executable.read()
    versions = glibc_versions(image)
    assert versions and versions[-1] >= (2, 14), versions
