# Shared by the command-line contract tests (sourced): a scratch folder $tmp removed on exit, $fail set to 1
# by any failed check.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
check() {  # check "description" expected_exit command...
  local what="$1" want="$2"; shift 2
  "$@" >"$tmp/out.txt" 2>"$tmp/err.txt"
  local got=$?
  if [ "$got" -ne "$want" ]; then
    echo "FAIL: $what: exit $got, expected $want"; sed 's/^/  | /' "$tmp/err.txt" | tail -5; fail=1
  else
    echo "ok: $what"
  fi
}
contains() {  # contains "description" file pattern
  if grep -q -- "$3" "$2"; then echo "ok: $1"; else echo "FAIL: $1: '$3' not in $2"; fail=1; fi
}
json() {  # json "description" file JQ_CONDITION: the condition holds on the JSON file (false or null fails)
  if jq -e "$3" "$2" >/dev/null; then echo "ok: $1"; else echo "FAIL: $1: '$3' does not hold in $2"; fail=1; fi
}
