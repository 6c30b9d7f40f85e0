#!/usr/bin/env bash
# Bring the real-file corpus into tests/corpus/ (or DEST) and check every byte.
#
# Each file listed in fetch-list.tsv is taken from
#   https://raw.githubusercontent.com/<owner>/<repo>/<commit>/<path>
# (or, with --from DIR, copied from a local copy laid out like the corpus), written to its
# local path, and checked against fetch-only.sha256. A file already present with the right
# hash is left alone. Exit status: 0 when every file is present and verified, 1 otherwise.
#
# usage: tests/corpus/fetch.sh [--from DIR] [--dest DIR] [--only PREFIX]
#   --from DIR     copy from DIR (same layout) instead of downloading
#   --dest DIR     write under DIR instead of the directory of this script
#   --only PREFIX  only files whose local path starts with PREFIX (e.g. nc/heidenhain/)
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
dest=$here
from=
only=
while [ $# -gt 0 ]; do
  case $1 in
    --from) from=$2; shift 2 ;;
    --dest) dest=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "fetch.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done

# Percent-encode a repository path for a URL, keeping '/'.
urlencode() {
  local s=$1 out= c i
  LC_ALL=C
  for ((i = 0; i < ${#s}; i++)); do
    c=${s:i:1}
    case $c in
      [a-zA-Z0-9._~/-]) out+=$c ;;
      *) printf -v c '%%%02X' "'$c"; out+=$c ;;
    esac
  done
  printf '%s' "$out"
}

sha256_of() {
  if command -v sha256sum >/dev/null; then sha256sum "$1" | cut -d' ' -f1
  else shasum -a 256 "$1" | cut -d' ' -f1; fi
}

# expected hash per local path
declare -A want
while IFS= read -r line; do
  [ -n "$line" ] || continue
  want["${line:66}"]=${line:0:64}
done < "$here/fetch-only.sha256"

ok=0 got=0 bad=0
while IFS=$'\t' read -r local repo commit path; do
  case $local in '#'*|'') continue ;; esac
  case $local in "$only"*) ;; *) continue ;; esac
  expect=${want[$local]:-}
  if [ -z "$expect" ]; then echo "no hash recorded for $local" >&2; bad=$((bad + 1)); continue; fi
  target=$dest/$local
  if [ -f "$target" ] && [ "$(sha256_of "$target")" = "$expect" ]; then ok=$((ok + 1)); continue; fi
  mkdir -p "$(dirname "$target")"
  tmp=$target.part
  if [ -n "$from" ]; then
    cp "$from/$local" "$tmp" 2>/dev/null || { echo "missing in $from: $local" >&2; bad=$((bad + 1)); continue; }
  else
    url="https://raw.githubusercontent.com/$repo/$commit/$(urlencode "$path")"
    if ! curl -fsSL --retry 3 -o "$tmp" "$url"; then
      echo "download failed: $url" >&2; rm -f "$tmp"; bad=$((bad + 1)); continue
    fi
  fi
  actual=$(sha256_of "$tmp")
  if [ "$actual" != "$expect" ]; then
    echo "hash mismatch for $local: expected $expect, got $actual" >&2
    rm -f "$tmp"; bad=$((bad + 1)); continue
  fi
  mv "$tmp" "$target"; got=$((got + 1))
done < "$here/fetch-list.tsv"

echo "corpus: $ok already present, $got fetched, $bad failed"
[ "$bad" -eq 0 ]
