#!/usr/bin/env bash
# Builds dist/python3-candp2_VERSION_all.deb, the candp2 Python package (python/, docs/python.md),
# without debhelper, beside candp2's own package:
#   packaging/deb/build-python-deb.sh VERSION OUT_DIR     (called by build-deb.sh)
#
# 1. a wheel of a copy of python/ (pip wheel, offline: no index, no build isolation, Debian's
#    setuptools), its version checked against VERSION (the CMake project's)
# 2. the wheel unpacked into /usr/lib/python3/dist-packages (Debian Python Policy §1.5: the
#    module and its .dist-info with the pytest11 entry point; no RECORD, dpkg owns the files),
#    the examples in /usr/share/doc/python3-candp2/examples, copyright, changelog.Debian.gz,
#    postinst/prerm byte-compiling as dh_python3 does, md5sums, lintian overrides
# 3. DEBIAN/control (Architecture: all; Depends: candp2 of the same version and the Debian
#    packages of the Python dependencies), Installed-Size from du
# 4. dpkg-deb --root-owner-group --build, then lintian (exit status 0 required)
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
version=${1:?usage: build-python-deb.sh VERSION OUT_DIR}
out=${2:?usage: build-python-deb.sh VERSION OUT_DIR}
mkdir -p "$out"
out=$(cd "$out" && pwd)
debversion="$version-1"
deb="$out/python3-candp2_${debversion}_all.deb"
pkg="$here/python3-candp2"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
stage="$work/stage"
site="$stage/usr/lib/python3/dist-packages"
doc="$stage/usr/share/doc/python3-candp2"

# 1. The wheel, built from a copy so that the source tree gets no build/ or egg-info.
cp -r "$root/python" "$work/src"
rm -rf "$work/src/build" "$work/src"/*.egg-info
find "$work/src" -name __pycache__ -prune -exec rm -rf {} +
/usr/bin/python3 -m pip wheel --quiet --no-deps --no-index --no-build-isolation \
  --wheel-dir "$work/wheel" "$work/src" >/dev/null
wheel=$(ls "$work"/wheel/candp2-*.whl)
case "$(basename "$wheel")" in
  "candp2-$version-"*) ;;
  *) echo "build-python-deb: $(basename "$wheel") is not version $version (python/candp2/__init__.py" \
       "__version__ must be the CMake project version)" >&2; exit 1 ;;
esac

# 2. The install tree.
install -d "$site" "$doc" "$stage/usr/share/lintian/overrides"
/usr/bin/python3 -m zipfile -e "$wheel" "$site"
rm -f "$site"/candp2-*.dist-info/RECORD
install -d "$doc/examples"
install -m 644 "$root"/python/examples/*.py "$root"/python/examples/pytest.ini "$doc/examples/"
install -m 644 "$here/copyright" "$doc/copyright"
gzip -9n <"$here/changelog" >"$doc/changelog.Debian.gz"
install -m 644 "$pkg/lintian-overrides" "$stage/usr/share/lintian/overrides/python3-candp2"
install -d "$stage/DEBIAN"
for s in postinst prerm; do install -m 755 "$pkg/$s" "$stage/DEBIAN/$s"; done
find "$stage" -type d -exec chmod 755 {} +
find "$stage/usr" -type f -exec chmod 644 {} +
(cd "$stage" && find usr -type f -print0 | sort -z | xargs -0 md5sum) >"$stage/DEBIAN/md5sums"

# 3. Control.
size=$(du -sk --exclude=DEBIAN "$stage" | cut -f1)
sed -e "s/@VERSION@/$debversion/g" -e "s/@SIZE@/$size/" "$pkg/control.in" >"$stage/DEBIAN/control"

# 4. The package, checked.
rm -f "$out"/python3-candp2_*.deb
dpkg-deb --root-owner-group -Zxz --build "$stage" "$deb" >/dev/null
echo "build-deb: $deb"
lintian --fail-on error,warning --suppress-tags-from-file /dev/null "$deb"
echo "build-deb: lintian clean"
