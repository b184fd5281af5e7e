#!/usr/bin/env bash
# Every thread's backtrace of each process given (gdb attaches for a moment):
# what a hung test's threads wait in, printed before the test is killed
# (tests/docs-check.sh). Prints a line instead where gdb is not installed
# (scripts/test.sh installs it).
# usage: tests/backtraces.sh PID...
command -v gdb > /dev/null || { echo "(gdb is not installed: no backtraces)"; exit 0; }
for pid in "$@"; do
  [ -r "/proc/$pid/cmdline" ] || continue
  echo "== process $pid: $(tr '\0' ' ' < "/proc/$pid/cmdline" | cut -c1-160)"
  timeout 120 gdb -p "$pid" -batch -nx -ex "set pagination off" -ex "thread apply all bt 30" \
    2> /dev/null | grep -E '^(Thread |#)'
done
