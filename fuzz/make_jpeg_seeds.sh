#!/bin/bash
# Writes fuzz/corpus/jpeg: small JPEGs made by ImageMagick (`convert`) of each kind esr reads or
# refuses (colour, grey, progressive, 4:2:0, CMYK), three with an EXIF APP1 segment, and those
# three APP1 payloads on their own (inputs not starting FF D8 go to the EXIF parser directly).
# Run by hand: fuzz/make_jpeg_seeds.sh
set -eu
out=$(cd "$(dirname "$0")" && pwd)/corpus/jpeg
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"

# "Exif\0\0", a TIFF header (II little-endian, MM big-endian; IFD0 at 8), IFD0's entries
# (tag, type, count, value: 0x0112 orientation SHORT 1 first in the value field), next IFD 0.
printf 'Exif\0\0II*\0\x08\0\0\0\x01\0\x12\x01\x03\0\x01\0\0\0\x06\0\0\0\0\0\0\0' > "$out/exif_le_orient6.app1"
printf 'Exif\0\0MM\0*\0\0\0\x08\0\x01\x01\x12\0\x03\0\0\0\x01\0\x08\0\0\0\0\0\0' > "$out/exif_be_orient8.app1"
# as a camera writes it: Make (ASCII at offset 62), Model (inline), orientation 3, XResolution
# (RATIONAL at 68), then the values the offsets point to
printf 'Exif\0\0II*\0\x08\0\0\0\x04\0'"\
"'\x0f\x01\x02\0\x06\0\0\0\x3e\0\0\0'"\
"'\x10\x01\x02\0\x04\0\0\0EOS\0'"\
"'\x12\x01\x03\0\x01\0\0\0\x03\0\0\0'"\
"'\x1a\x01\x05\0\x01\0\0\0\x44\0\0\0'"\
"'\0\0\0\0Canon\0\x48\0\0\0\x01\0\0\0' > "$out/exif_le_camera_orient3.app1"

im="-size 5x3 gradient:#c03010-#1040e0"
convert $im -quality 90 "$out/rgb.jpg"
convert $im -colorspace Gray -quality 90 "$out/grey.jpg"
convert $im -interlace Plane -quality 90 "$out/progressive.jpg"
convert -size 16x16 gradient:#c03010-#1040e0 -sampling-factor 2x2 -quality 75 "$out/subsampled_420.jpg"
convert $im -colorspace CMYK -quality 90 "$out/cmyk.jpg"
for exif in exif_le_orient6 exif_be_orient8 exif_le_camera_orient3; do
  cp "$out/$exif.app1" "$tmp/exif.app1"
  convert $im -profile "APP1:$tmp/exif.app1" -quality 90 "$out/$exif.jpg"
done
ls -l "$out"
