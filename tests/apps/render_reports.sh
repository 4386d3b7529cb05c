#!/bin/sh
# The HTML reports in a real browser: sph_calibrate's (the undeclared example, the paper's example
# with the devices of an acquisition in its header, one compared with an earlier calibration of another
# model, and the separation example's one placement with its form known) and sph_measure's (NIST sphere 1) are
# well formed (xmllint --html), and headless Chromium renders each to a PNG and prints it to an A4 PDF
# (pdfinfo): a page for each section that starts one, the undeclared example in at most 6 pages.
# Usage: render_reports.sh SPH_CALIBRATE SPH_MEASURE SOURCE_DIR WORK_DIR
# Exits 77 (skipped) when chromium, pdfinfo or xmllint is missing.
set -eu
calibrate=$1 measure=$2 source=$3 work=$4
chromium=$(command -v chromium || command -v chromium-browser || true)
for tool in "$chromium:chromium" "$(command -v pdfinfo || true):pdfinfo (poppler-utils)" \
            "$(command -v xmllint || true):xmllint (libxml2-utils)"; do
  if [ -z "${tool%%:*}" ]; then
    echo "skipped: ${tool#*:} is not installed (cmake/install-deps.sh installs it)"
    exit 77
  fi
done
rm -rf "$work"
mkdir -p "$work"
"$calibrate" "$source/data/example/undeclared/points.txt" -q --report "$work/calibration.html"
"$measure" --xyz "$source/tests/data/nist-ats-l2-sphere/sph1.ds" -q --report "$work/measurement.html"
# A points file acquired by sph_acquired names the devices it identified over SDO in its header. A
# replay of a simulated log runs no SDO, so the lines are written here as the daemon writes them
# (CanopenMaster::HeaderFields()), into the example's header before its columns.
sed '/^# columns:/i\
# device_theta_encoder: node 1; name "sph_cansim theta encoder"; vendor_id 0x00535048; product_code 0x00004060; revision 0x00010000; serial 0x00010001; tpdo 1 cob_id 0x181\
# device_phi_encoder: node 2; name "sph_cansim phi encoder"; vendor_id 0x00535048; product_code 0x00004061; revision 0x00010000; serial 0x00010002; tpdo 1 cob_id 0x182\
# device_probe: node 3; name "sph_cansim probe"; vendor_id 0x00535048; product_code 0x00002000; revision 0x00010000; serial 0x00010003; tpdo 1 cob_id 0x183' \
  "$source/data/example/points.txt" >"$work/acquired.txt"
"$calibrate" "$work/acquired.txt" -q --report "$work/calibration_devices.html"
if ! grep -q '>sph_cansim probe</span></td>' "$work/calibration_devices.html"; then
  echo "$work/calibration_devices.html: no devices table"
  exit 1
fi
# A comparison with an earlier calibration of another model (the seven errors alone): the verdict's
# rows of the earlier model fitted to today's readings, today's own beside them.
"$calibrate" "$source/data/example/undeclared/points.txt" -q --no-trace -o "$work/earlier.json"
"$calibrate" "$source/data/example/undeclared/points.txt" -q --compare "$work/earlier.json" \
  --report "$work/calibration_compare.html"
if ! grep -q '>earlier, refitted</td>' "$work/calibration_compare.html"; then
  echo "$work/calibration_compare.html: no like-for-like comparison"
  exit 1
fi
# The everyday calibration with the sphere's form known from the separation example: the known
# form's section.
"$calibrate" "$source/data/example/separation/points.txt" -q -o "$work/separated.json"
"$calibrate" "$source/data/example/separation/one_placement.txt" -q --sphere-form "$work/separated.json" \
  --report "$work/calibration_known_form.html"
if ! grep -q '<h2>The sphere&#39;s known form</h2>' "$work/calibration_known_form.html"; then
  echo "$work/calibration_known_form.html: no section of the known form"
  exit 1
fi
for name in calibration measurement calibration_devices calibration_compare calibration_known_form; do
  page=$work/$name.html
  # libxml2's HTML parser: any complaint fails.
  complaints=$(xmllint --html --noout "$page" 2>&1) || true
  if [ -n "$complaints" ]; then
    echo "$page: xmllint --html: $complaints"
    exit 1
  fi
  # A profile of its own in the work folder: nothing read from or left in the user's.
  "$chromium" --headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir="$work/profile" \
    --window-size=1000,1400 --screenshot="$work/$name.png" "file://$page" >/dev/null 2>&1
  "$chromium" --headless --no-sandbox --disable-gpu --user-data-dir="$work/profile" --no-pdf-header-footer \
    --print-to-pdf="$work/$name.pdf" "file://$page" >/dev/null 2>&1
  if [ ! -s "$work/$name.png" ] || [ ! -s "$work/$name.pdf" ]; then
    echo "$page: chromium wrote no PNG or no PDF"
    exit 1
  fi
  info=$(pdfinfo "$work/$name.pdf")
  pages=$(echo "$info" | sed -n 's/^Pages: *//p')
  sections=$(grep -o 'class="section' "$page" | wc -l)
  new_pages=$(grep -o 'class="section page"' "$page" | wc -l)
  echo "$name: $sections sections, $new_pages of them from a new page, $pages pages"
  if [ "$sections" -lt 4 ] || [ "$pages" -le "$new_pages" ] || [ "$pages" -gt $((2 * sections)) ]; then
    echo "$name.pdf: $pages pages for $sections sections ($new_pages from a new page after the first)"
    exit 1
  fi
  # The undeclared example, every number a reviewer needs, in at most 6 A4 pages.
  if [ "$name" = calibration ] && [ "$pages" -gt 6 ]; then
    echo "$name.pdf: $pages pages, more than 6"
    exit 1
  fi
  if ! echo "$info" | grep -q '^Page size:.*(A4)'; then
    echo "$name.pdf is not A4: $(echo "$info" | grep '^Page size')"
    exit 1
  fi
done
echo "rendered: $work"
