# Sourced by the bench scripts that read bench_accuracy_diff's line of key=value figures.
# kv LINE KEY: the value of KEY in LINE (the whole LINE when KEY is absent).
kv() { sed -E "s/.*(^| )$2=([^ ]*).*/\\2/" <<<"$1"; }
