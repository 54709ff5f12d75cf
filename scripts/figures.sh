#!/usr/bin/env bash
# Regenerates the figures of every shipped case in the docs: each case of cases/ run as its
# users run it (`geardyn run CASE --plot`) and, for a case with more than one degree of freedom,
# its modes (`geardyn modes CASE`: the Campbell diagram), the figures copied to
# docs/images/cases/ and docs/gallery.md written to show them with the commands that drew them.
# About 40 s on 2 cores after the build. Files of docs/images/cases/ that no case draws
# any more are removed (the folder is this script's alone).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --tool
geardyn=build/release/geardyn
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
images=docs/images/cases
rm -rf "$images.new"
mkdir -p "$images.new"

gallery="$work/gallery.md"
{
  echo "# The shipped cases' figures"
  echo
  echo "Every case of \`cases/\` as its users run it, the figures as geardyn draws them. Written by"
  echo "\`bash scripts/figures.sh\`, which runs the commands below and copies their figures here;"
  echo "the numbers behind each figure are in the run's folder (docs/outputs.md)."
} >"$gallery"

for file in cases/*.toml; do
  name=$(basename "$file" .toml)
  description=$(sed -n 's/^description = "\(.*\)"$/\1/p' "$file")
  echo "figures: $name"
  "$geardyn" run "$file" --out "$work/$name/run" --plot >"$work/$name.run.txt"
  {
    echo
    echo "## $name"
    echo
    [[ -n "$description" ]] && echo "$description." && echo
    echo '```sh'
    echo "geardyn run cases/$name.toml --out DIR --plot"
    echo '```'
    echo
    echo "$(grep -m1 '^  steady part' "$work/$name.run.txt" | sed 's/^  steady part *//' || true)" |
      sed 's/^/Steady part: /'
  } >>"$gallery"
  for png in "$work/$name/run"/*.png; do
    figure=$(basename "$png" .png)
    cp "$png" "$images.new/${name}_$figure.png"
    printf '\n![%s: %s](images/cases/%s_%s.png)\n' "$name" "$figure" "$name" "$figure" >>"$gallery"
  done
  # A train or a coupled pair has modes; the one-degree forms have their one natural frequency.
  if grep -Eq '^form = "(train|coupled)"' "$file"; then
    "$geardyn" modes "$file" --out "$work/$name/modes" >/dev/null
    cp "$work/$name/modes/campbell.png" "$images.new/${name}_campbell.png"
    {
      echo
      echo '```sh'
      echo "geardyn modes cases/$name.toml --out DIR"
      echo '```'
      printf '\n![%s: Campbell diagram](images/cases/%s_campbell.png)\n' "$name" "$name"
    } >>"$gallery"
  fi
done

rm -rf "$images"
mv "$images.new" "$images"
cp "$gallery" docs/gallery.md
echo "figures: $(find "$images" -name '*.png' | wc -l) figures in $images, docs/gallery.md"
