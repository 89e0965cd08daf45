#!/usr/bin/env bash
# report.html in a real browser: `storey map` on a simulated building, then its report
# loaded offline in headless Chromium (Debian's chromium-headless-shell) through a page
# that reads it in a frame. Fails on any console message of the report, an image that
# does not decode, a missing section, the 3D pictures or timeline missing, an interactive
# view that draws nothing, does not turn when dragged or does not hide a floor when its box
# is cleared, or the report with its images at 5 MB or more.
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
  // The interactive view: pixels drawn, a drag that turns it, a floor's box that hides it.
  const w = d.defaultView, view = d.getElementById("view3d");
  let ink = -1, turned = 0, hidden = 0;
  if (view) {
    const copy = d.createElement("canvas");
    copy.width = view.width;
    copy.height = view.height;
    const reader = copy.getContext("2d", {willReadFrequently: true});
    const inked = () => {
      reader.drawImage(view, 0, 0);
      const p = reader.getImageData(0, 0, view.width, view.height).data;
      let n = 0;
      for (let i = 0; i < p.length; i += 4) if (p[i + 3] > 0 && p[i] + p[i + 1] + p[i + 2] < 720) ++n;
      return n;
    };
    ink = inked();
    const before = view.toDataURL();
    const r = view.getBoundingClientRect();
    const x = r.left + r.width / 2, y = r.top + r.height / 2;
    view.dispatchEvent(new w.PointerEvent("pointerdown", {clientX: x, clientY: y, bubbles: true}));
    w.dispatchEvent(new w.PointerEvent("pointermove", {clientX: x + 80, clientY: y + 20}));
    w.dispatchEvent(new w.PointerEvent("pointerup", {clientX: x + 80, clientY: y + 20}));
    turned = view.toDataURL() !== before ? 1 : 0;
    const box = d.querySelector("#view3d-controls input[data-floor]");
    const full = inked();
    if (box) box.click();
    hidden = inked() < full ? 1 : 0;
  }
  console.log("storey-check images=" + images.length + " broken=" + broken.length + " [" +
              broken.join(",") + "] svg=" + d.querySelectorAll("svg").length + " view3d=" + ink +
              " turned=" + turned + " hidden=" + hidden + " sections=" + sections.join("|"));
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
[ "$(field view3d)" -gt 1000 ] 2>/dev/null || fail "the 3D view drew $(field view3d) pixels"
[ "$(field turned)" = "1" ] || fail "the 3D view did not turn when dragged"
[ "$(field hidden)" = "1" ] || fail "clearing a floor's box did not hide it in the 3D view"
for section in Summary Floors Timeline "3D view"; do
  [[ "|$sections|" == *"|$section|"* ]] || fail "no $section section"
done
grep -q 'building_after.png' "$out/report.html" || fail "no 3D picture"
# The report and every file it shows.
bytes=$(stat -c %s "$out/report.html")
while read -r file; do
  bytes=$((bytes + $(stat -c %s "$out/$file")))
done < <(grep -o 'src="[^"]*"' "$out/report.html" | sed 's/src="\(.*\)"/\1/' | sort -u)
echo "$building: report with its images: $bytes bytes"
[ "$bytes" -lt $((5 * 1024 * 1024)) ] || fail "report with its images is $bytes bytes (5 MB or more)"
exit $status
