# Shared by the command-line tests (source it): a scratch folder $tmp removed on exit, fail, and
#   expect_error PATTERN COMMAND...        a non-zero exit, stderr one line naming PATTERN;
#   expect_error_line PATTERN COMMAND...   the same, progress lines before the error allowed (one
#                                          "facecast: " line naming PATTERN).
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
_expect_error() {
  local filter=$1 pattern=$2; shift 2
  if "$@" 2>"$tmp/err"; then fail "succeeded: $*"; fi
  grep "$filter" "$tmp/err" >"$tmp/error" || true
  grep -q -- "$pattern" "$tmp/error" || fail "message lacks '$pattern': $(cat "$tmp/err")"
  [[ $(wc -l <"$tmp/error") -eq 1 ]] || fail "more than one line: $(cat "$tmp/err")"
}
expect_error() { _expect_error "" "$@"; }
expect_error_line() { _expect_error "^facecast: " "$@"; }
