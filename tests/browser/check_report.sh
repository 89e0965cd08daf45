#!/usr/bin/env bash
# report.html in a real browser: `storey map` on a simulated building, then its report
# loaded offline in headless Chromium (Debian's chromium-headless-shell) through a page
# that reads it in a frame. Fails on any console message of the report, an image that
# does not decode, a missing section, the 3D view or timeline missing, or the report with
# its images at 5 MB or more.
#   check_report.sh STOREY CHROMIUM SOURCE_DIR WORK_DIR BUILDING DOMAIN
set -euo pipefail
storey=$1 chromium=$2 source=$3 building=$5 domain=$6
work=$(realpath -m "$4")  # a file:// address needs an absolute path
out="$work/$building"
rm -rf "$out"
mkdir -p "$out"
if ! "$storey" map "$source/config/buildings/$building.yaml" --output "$out" --domain "$domain" \
  --quiet >"$work/$building.map.log" 2>&1; then
  cat "$work/$building.map.log"
  echo "FAIL: storey map $building"
  exit 1
fi
# The frame's document is readable from the page only with file access across files.
cat >"$out/check.html" <<'PAGE'
<!DOCTYPE html><html><body><iframe id="r" src="report.html" width="1280" height="900"></iframe>
<script>
document.getElementById("r").addEventListener("load", () => {
  const d = document.getElementById("r").contentDocument;
  const images = Array.from(d.images);
  const broken = images.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute("src"));
  const sections = Array.from(d.querySelectorAll("h2")).map(h => h.textContent);
  console.log("storey-check images=" + images.length + " broken=" + broken.length + " [" +
              broken.join(",") + "] svg=" + d.querySelectorAll("svg").length + " sections=" +
              sections.join("|"));
});
</script></body></html>
PAGE
"$chromium" --no-sandbox --disable-gpu --disable-dev-shm-usage --allow-file-access-from-files --enable-logging=stderr \
  --v=0 --virtual-time-budget=20000 --dump-dom "file://$out/check.html" >/dev/null \
  2>"$work/$building.chromium.log" || true
status=0
fail() {
  echo "FAIL: $building: $*"
  status=1
}
result=$(grep -o 'storey-check [^"]*' "$work/$building.chromium.log" || true)
echo "$building: ${result:-no result}"
[ -n "$result" ] || fail "the check page did not run (see $work/$building.chromium.log)"
# Console output other than the check's own line: the report's errors or the page's.
if grep 'CONSOLE' "$work/$building.chromium.log" | grep -v 'storey-check'; then
  fail "console messages above"
fi
field() { sed -n "s/.*$1=\([^ ]*\).*/\1/p" <<<"$result"; }
expected_images=$(grep -o '<img ' "$out/report.html" | wc -l)
[ "$(field images)" = "$expected_images" ] || fail "$(field images) images loaded, the report has $expected_images"
[ "$(field broken)" = "0" ] || fail "images that do not decode: $result"
[ "$(field svg)" != "0" ] && [ -n "$(field svg)" ] || fail "no timeline drawing"
sections=${result#* sections=}
for section in Summary Floors Timeline; do
  [[ "|$sections|" == *"|$section|"* ]] || fail "no $section section"
done
grep -q 'building_after.png' "$out/report.html" || fail "no 3D view"
# The report and every file it shows.
bytes=$(stat -c %s "$out/report.html")
while read -r file; do
  bytes=$((bytes + $(stat -c %s "$out/$file")))
done < <(grep -o 'src="[^"]*"' "$out/report.html" | sed 's/src="\(.*\)"/\1/' | sort -u)
echo "$building: report with its images: $bytes bytes"
[ "$bytes" -lt $((5 * 1024 * 1024)) ] || fail "report with its images is $bytes bytes (5 MB or more)"
exit $status
