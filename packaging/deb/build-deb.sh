#!/usr/bin/env bash
# Builds dist/candp2_VERSION_ARCH.deb from an already built Release tree, without debhelper, and
# beside it dist/python3-candp2_VERSION_all.deb (the Python package, build-python-deb.sh):
#   packaging/deb/build-deb.sh BUILD_DIR OUT_DIR      (tools/setup.sh deb: build-release dist)
#
# 1. DESTDIR=STAGE cmake --install BUILD_DIR --prefix /usr (CMakeLists.txt: /etc/candp2, the
#    unit in /lib/systemd/system, share/candp2, man pages)
# 2. Debian's finishing touches: stripped executables, gzipped man pages, copyright,
#    changelog.Debian.gz, maintainer scripts (the dh_installsystemd conventions, by hand),
#    conffiles, md5sums, lintian overrides
# 3. DEBIAN/control with Depends from dpkg-shlibdeps, Installed-Size from du
# 4. dpkg-deb --root-owner-group --build, then lintian (exit status 0 required)
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
build=$(cd "${1:?usage: build-deb.sh BUILD_DIR OUT_DIR}" && pwd)
out=${2:?usage: build-deb.sh BUILD_DIR OUT_DIR}
mkdir -p "$out"
out=$(cd "$out" && pwd)

version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' "$build/CMakeCache.txt")
[ -n "$version" ] || { echo "build-deb: no project version in $build/CMakeCache.txt" >&2; exit 1; }
debversion="$version-1"
arch=$(dpkg --print-architecture)
deb="$out/candp2_${debversion}_${arch}.deb"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
stage="$work/stage"
doc="$stage/usr/share/doc/candp2"

# 1. The install tree.
DESTDIR="$stage" cmake --install "$build" --prefix /usr >/dev/null

# 2. Debian's layout rules (Debian policy §10.1, §12.1, §12.5, §12.7).
for exe in "$stage"/usr/bin/*; do
  strip --remove-section=.comment --remove-section=.note --strip-unneeded "$exe"
done
find "$stage/usr/share/man" -type f -exec gzip -9n {} +
install -d "$doc" "$stage/usr/share/lintian/overrides"
install -m 644 "$here/copyright" "$doc/copyright"
gzip -9n <"$here/changelog" >"$doc/changelog.Debian.gz"
install -m 644 "$here/lintian-overrides" "$stage/usr/share/lintian/overrides/candp2"
install -d "$stage/DEBIAN"
for s in postinst prerm postrm; do install -m 755 "$here/$s" "$stage/DEBIAN/$s"; done
# Every file below /etc is a conffile (Debian policy §10.7.2).
(cd "$stage" && find etc -type f -printf '/%p\n' | sort) >"$stage/DEBIAN/conffiles"
find "$stage" -type d -exec chmod 755 {} +
find "$stage/usr/share" "$stage/etc" "$stage/lib" -type f -exec chmod 644 {} +
# md5sums of every file but the conffiles (dpkg keeps those itself), like dh_md5sums.
(cd "$stage" && find usr lib -type f -print0 | sort -z | xargs -0 md5sum) >"$stage/DEBIAN/md5sums"

# 3. Depends: dpkg-shlibdeps needs a debian/control naming the package; a stub in the work dir.
mkdir -p "$work/src/debian"
printf 'Source: candp2\n\nPackage: candp2\nArchitecture: any\n' >"$work/src/debian/control"
shlibs=$(cd "$work/src" && dpkg-shlibdeps -O -e"$stage/usr/bin/candp2d" \
  -e"$stage/usr/bin/candp2" -e"$stage/usr/bin/candp2-drive" 2>/dev/null |
  sed -n 's/^shlibs:Depends=//p')
[ -n "$shlibs" ] || { echo "build-deb: dpkg-shlibdeps found no dependencies" >&2; exit 1; }
size=$(du -sk --exclude=DEBIAN "$stage" | cut -f1)
sed -e "s/@VERSION@/$debversion/" -e "s/@ARCH@/$arch/" -e "s/@DEPENDS@/$shlibs/" \
  -e "s/@SIZE@/$size/" "$here/control.in" >"$stage/DEBIAN/control"

# 4. The package, checked.
rm -f "$out"/candp2_*.deb
dpkg-deb --root-owner-group -Zxz --build "$stage" "$deb" >/dev/null
echo "build-deb: $deb"
echo "build-deb: Depends: $shlibs"
lintian --fail-on error,warning --suppress-tags-from-file /dev/null "$deb"
echo "build-deb: lintian clean"

# 5. The Python package of the same version.
"$here/build-python-deb.sh" "$version" "$out"
