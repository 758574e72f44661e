#!/usr/bin/env bash
# Issue 9: no unwrap/expect/panic reachable from user input.
#
# Scans the non-test Rust source of the binary's input paths (src/, crates/pn-runtime, pn-drivers and pn-kernels)
# for `.unwrap()`, `.expect(` and `panic!` outside `#[cfg(test)]` items and comments.
# Every remaining occurrence must be listed in .ci/no-panics.allow as
#     <path> | <code fragment on the line> | <one-line justification>
# (matched by path and fragment, not by line number, so edits elsewhere do not break it).
# Exits 1 on an unlisted occurrence or an entry without a justification; warns about
# entries that no longer match anything.
set -euo pipefail
cd "$(dirname "$0")/.."
allow=.ci/no-panics.allow
status=0

# Entries: path|fragment|justification (whitespace around fields trimmed).
mapfile -t entries < <(grep -v '^\s*#' "$allow" | grep -v '^\s*$' || true)
declare -A used=()
for e in "${entries[@]}"; do
    just=$(echo "$e" | cut -d'|' -f3- | sed 's/^ *//;s/ *$//')
    if [ -z "$just" ]; then
        echo "no-panics: allowlist entry without a justification: $e" >&2
        status=1
    fi
done

# Prints "path:line:code" for occurrences outside #[cfg(test)] items and comments.
scan() {
    awk '
    FNR == 1 { depth = 0; skipping = 0; pending = 0 }
    {
        line = $0
        code = line
        gsub(/\047.\047/, "", code)         # drop char literals such as the brace char
        sub(/\/\/.*$/, "", code)            # drop line comments (incl. doc comments)
        if (line ~ /^[ \t]*#\[cfg\(test\)\]/) { pending = 1 }
        opens = gsub(/\{/, "{", code); closes = gsub(/\}/, "}", code)
        if (pending && opens > 0 && !skipping) { skipping = 1; base = depth; pending = 0 }
        else if (pending && code ~ /;[ \t]*$/ && !skipping) { pending = 0; next }
        in_test = (skipping || pending)
        depth += opens - closes
        if (!in_test && code ~ /\.unwrap\(\)|\.expect\(|panic!/) {
            printf "%s:%d:%s\n", FILENAME, FNR, line
        }
        if (skipping && depth <= base) { skipping = 0 }
    }' "$@"
}

mapfile -t files < <(find src crates/pn-runtime/src crates/pn-drivers/src crates/pn-kernels/src -name '*.rs' | sort)
while IFS= read -r hit; do
    [ -z "$hit" ] && continue
    path=${hit%%:*}
    rest=${hit#*:}
    code=${rest#*:}
    ok=0
    for i in "${!entries[@]}"; do
        e=${entries[$i]}
        epath=$(echo "$e" | cut -d'|' -f1 | sed 's/^ *//;s/ *$//')
        frag=$(echo "$e" | cut -d'|' -f2 | sed 's/^ *//;s/ *$//')
        if [ "$epath" = "$path" ] && [[ "$code" == *"$frag"* ]]; then
            ok=1
            used[$i]=1
        fi
    done
    if [ $ok = 0 ]; then
        echo "no-panics: $hit" >&2
        status=1
    fi
done < <(scan "${files[@]}")

for i in "${!entries[@]}"; do
    if [ -z "${used[$i]:-}" ]; then
        echo "no-panics: warning: allowlist entry matches nothing: ${entries[$i]}" >&2
    fi
done
if [ $status != 0 ]; then
    echo "no-panics: fix these (return an error) or list them in $allow with a reason" >&2
else
    echo "no-panics: ok"
fi
exit $status
