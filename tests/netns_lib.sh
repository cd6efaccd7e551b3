# Helpers for tests that need a private multicast network: each test creates its own network namespace(s) and
# deletes them on exit, so LCM traffic never leaves this machine and parallel tests do not hear each other.
# Source this file; then call netns_require, netns_create NAME, and run commands with `in_ns NAME cmd...`.

NETNS_CREATED=()

netns_cleanup() {
  local ns
  for ns in "${NETNS_CREATED[@]}"; do
    # End whatever still runs inside, then delete the namespace.
    for pid in $(ip netns pids "$ns" 2>/dev/null); do kill -9 "$pid" 2>/dev/null || true; done
    ip netns delete "$ns" 2>/dev/null || true
  done
}

# Exit 77 (CTest: skipped) when namespaces cannot be made here (not root, no iproute2).
netns_require() {
  if [ "$(id -u)" -ne 0 ] || ! command -v ip >/dev/null; then
    echo "SKIP: network namespaces need root and iproute2"
    exit 77
  fi
  trap netns_cleanup EXIT
}

# netns_create NAME: a namespace whose loopback carries multicast (LCM udpm with ttl=0).
netns_create() {
  local ns="$1"
  ip netns add "$ns" || { echo "SKIP: cannot create network namespace $ns"; exit 77; }
  NETNS_CREATED+=("$ns")
  ip -n "$ns" link set lo up
  ip -n "$ns" link set lo multicast on
  ip -n "$ns" route add 224.0.0.0/4 dev lo
}

# netns_create_pair A B SUBNET_PREFIX: two namespaces ("robot" and "workstation") joined by a veth pair,
# with multicast routed over the link (LCM udpm with ttl=1).
netns_create_pair() {
  local a="$1" b="$2" prefix="$3"
  # Interface names are limited to 15 characters: name the veth ends by this shell's pid, not by the namespaces.
  local va="vo$$a" vb="vo$$b"
  ip netns add "$a" || { echo "SKIP: cannot create network namespace $a"; exit 77; }
  NETNS_CREATED+=("$a")
  ip netns add "$b" || { echo "SKIP: cannot create network namespace $b"; exit 77; }
  NETNS_CREATED+=("$b")
  ip link add "$va" netns "$a" type veth peer name "$vb" netns "$b"
  ip -n "$a" link set lo up
  ip -n "$b" link set lo up
  ip -n "$a" addr add "$prefix.1/24" dev "$va"
  ip -n "$b" addr add "$prefix.2/24" dev "$vb"
  ip -n "$a" link set "$va" up multicast on
  ip -n "$b" link set "$vb" up multicast on
  ip -n "$a" route add 224.0.0.0/4 dev "$va"
  ip -n "$b" route add 224.0.0.0/4 dev "$vb"
}

in_ns() {
  local ns="$1"
  shift
  ip netns exec "$ns" "$@"
}

# A namespace name unique to this test run.
netns_name() { echo "objscan-$1-$$"; }

fail() {
  echo "FAIL: $*"
  exit 1
}
