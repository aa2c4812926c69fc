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
ate() {  # ate GT EST: ATE RMSE in metres ($bin: the rgbdmap program)
  "$bin" eval --gt "$1" --est "$2" --json | jq -r '.ate.rmse_m'
}
below() {  # below "description" value bound
  if [[ "$2" =~ ^[0-9.eE+-]+$ ]] && awk -v v="$2" -v b="$3" 'BEGIN { exit !(v + 0 < b + 0) }'; then echo "ok: $1 ($2 < $3)"; else echo "FAIL: $1: $2 not < $3"; fail=1; fi
}
one_error_line() {  # one_error_line "description" file: exactly one "error]" log line in the file
  local n; n=$(grep -c 'error\]' "$2")
  if [ "$n" -eq 1 ]; then echo "ok: $1"; else echo "FAIL: $1: $n error lines"; sed 's/^/  | /' "$2"; fail=1; fi
}
