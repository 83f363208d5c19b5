#!/bin/sh
# Make the secrets of the `secure` deployment: a random password for each Zenoh user,
# a certificate authority and the router's TLS certificate, and the router's config,
# in a directory that git ignores and Docker builds never copy (docker/ is outside
# the build context).
#   docker/make-secrets.sh [-d DIR] [-r ROBOTS] [-n NAMES] [USER...]
# DIR defaults to docker/secure/secrets. ROBOTS (comma-separated, default r1) are
# the robot ids: each gets its own service logins, `<service>-<robot>` (`sim-r1`,
# `vps-r1`, ..., `driver-r1`), which may act on that robot's keys only, and an
# operator, `operator-<robot>`, who may command that robot and no other. NAMES
# (comma-separated, default localhost,127.0.0.1,router) are the host names and
# addresses clients reach the router at; its certificate names them. The users are
# those, `viewer` (may only watch), and the USERs given (watch only, like viewer).
# Writes (every file 0600, DIR 0700):
#   DIR/users.txt           the router's users file, one `user:password` line per user
#   DIR/<user>.json5        that user's Zenoh client config (ZENOH_CONFIG=DIR/<user>.json5):
#                           its login, and the CA to trust on tls/ endpoints
#   DIR/ca.pem, ca.key      the deployment's certificate authority
#   DIR/router.pem, .key    the router's certificate (for NAMES) and key
#   DIR/router.json5        config/secure/router.json5 filled in, for a router on the host:
#                           zenav router --listen tls/127.0.0.1:7447 --zenoh-config DIR/router.json5
#   DIR/router.docker.json5 the same with the paths of the compose `secure` deployment
# A user that already has a password keeps it, the CA and the router's certificate
# stay; delete DIR to renew them all (or DIR/router.pem alone for other NAMES).
# Run as root, the files the containers read are given to the image's user (10001);
# otherwise run compose as yourself (ZENAV_UID=$(id -u) ZENAV_GID=$(id -g)).
set -eu

here=$(cd "$(dirname "$0")" && pwd)
dir="$here/secure/secrets"
robots=r1
names=localhost,127.0.0.1,router
while getopts d:r:n: opt; do
    case $opt in
        d) dir=$OPTARG ;;
        r) robots=$OPTARG ;;
        n) names=$OPTARG ;;
        *) echo "usage: make-secrets.sh [-d DIR] [-r ROBOTS] [-n NAMES] [USER...]" >&2; exit 2 ;;
    esac
done
shift $((OPTIND - 1))

check() {  # check NAME WHAT: a user name or robot id is A-Z a-z 0-9 _ -
    case $1 in
        *[!A-Za-z0-9_-]* | "") echo "make-secrets: bad $2 '$1' (use A-Z a-z 0-9 _ -)" >&2; exit 2 ;;
    esac
}
robots=$(echo "$robots" | tr ',' ' ')
services="sim odometry vps localizer navigator motor driver"
logins=""  # every robot's own logins: its services' and its operator's
for robot in $robots; do
    check "$robot" "robot id"
    for svc in $services operator; do
        logins="$logins $svc-$robot"
    done
done
[ -n "$logins" ] || { echo "make-secrets: no robot ids (-r r1,r2)" >&2; exit 2; }
command -v openssl >/dev/null || { echo "make-secrets: needs openssl (apt-get install openssl)" >&2; exit 2; }

umask 077
mkdir -p "$dir"
chmod 700 "$dir"
dir=$(cd "$dir" && pwd)
printf '*\n' > "$dir/.gitignore"
touch "$dir/users.txt"

# ------------------------------------------------------------------ TLS
if [ ! -f "$dir/ca.pem" ]; then
    openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 3650 \
        -subj "/CN=zenav CA" -keyout "$dir/ca.key" -out "$dir/ca.pem" 2>/dev/null
    rm -f "$dir/router.pem"  # a new CA: a new router certificate
    echo "make-secrets: new certificate authority"
fi
if [ ! -f "$dir/router.pem" ]; then
    san=""
    for name in $(echo "$names" | tr ',' ' '); do
        case $name in
            *:* | *[0-9].*[0-9].*[0-9].*[0-9]) san="$san,IP:$name" ;;
            *) san="$san,DNS:$name" ;;
        esac
    done
    printf 'subjectAltName=%s\nbasicConstraints=CA:FALSE\nkeyUsage=digitalSignature\nextendedKeyUsage=serverAuth\n' "${san#,}" > "$dir/router.ext"
    openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj "/CN=zenav router" \
        -keyout "$dir/router.key" -out "$dir/router.csr" 2>/dev/null
    openssl x509 -req -in "$dir/router.csr" -CA "$dir/ca.pem" -CAkey "$dir/ca.key" -CAcreateserial \
        -days 825 -extfile "$dir/router.ext" -out "$dir/router.pem" 2>/dev/null
    rm -f "$dir/router.csr" "$dir/router.ext" "$dir/ca.srl"
    echo "make-secrets: new router certificate for $names"
fi
ca=$(openssl base64 -A < "$dir/ca.pem")

# ------------------------------------------------------------------ users
for user in $logins viewer "$@"; do
    check "$user" "user name"
    password=$(sed -n "s/^$user://p" "$dir/users.txt")
    if [ -z "$password" ]; then
        password=$(od -An -N24 -tx1 /dev/urandom | tr -d ' \n')  # 192 random bits, hex
        printf '%s:%s\n' "$user" "$password" >> "$dir/users.txt"
        echo "make-secrets: new password for $user"
    fi
    printf '{ transport: { auth: { usrpwd: { user: "%s", password: "%s" } }, link: { tls: { root_ca_certificate_base64: "%s" } } } }\n' \
        "$user" "$password" "$ca" > "$dir/$user.json5"
done

# ------------------------------------------------------------------ router
# Each block between `@robot begin` and `@robot end` once per robot id, that id for @robot.
awk -v robots="$robots" '
    BEGIN { n = split(robots, robot, " ") }
    /^[ \t]*\/\/ @robot begin/ { inside = 1; body = ""; print; next }
    /^[ \t]*\/\/ @robot end/ {
        for (i = 1; i <= n; i++) { b = body; gsub(/@robot/, robot[i], b); printf "%s", b }
        inside = 0; print; next
    }
    inside { body = body $0 "\n"; next }
    { print }
' "$here/../config/secure/router.json5" > "$dir/router.docker.json5"
sed -e "s|/run/secrets/zenoh_users|$dir/users.txt|" \
    -e "s|/run/secrets/zenoh_router_cert|$dir/router.pem|" \
    -e "s|/run/secrets/zenoh_router_key|$dir/router.key|" \
    "$dir/router.docker.json5" > "$dir/router.json5"

if [ "$(id -u)" = 0 ]; then
    for robot in $robots; do
        for svc in $services; do
            chown 10001:10001 "$dir/$svc-$robot.json5"  # the image's user, which the compose deployment runs as
        done
    done
    for f in users.txt router.pem router.key router.docker.json5; do
        chown 10001:10001 "$dir/$f"  # the image's user, which the compose deployment runs as
    done
fi
echo "make-secrets: secrets in $dir (robots:$(printf ' %s' $robots); logins:$logins)"
