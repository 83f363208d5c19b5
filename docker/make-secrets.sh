#!/bin/sh
# Make the secrets of the `secure` deployment: a random password for each Zenoh user,
# in a directory that git ignores and Docker builds never copy (docker/ is outside
# the build context).
#   docker/make-secrets.sh [-d DIR] [USER...]
# DIR defaults to docker/secure/secrets. USERs are added to the default users: the
# six services, `operator` (may command the robot) and `viewer` (may only watch).
# Writes:
#   DIR/users.txt      the router's users file, one `user:password` line per user
#   DIR/<user>.json5   that user's Zenoh client config (ZENOH_CONFIG=DIR/<user>.json5)
#   DIR/router.json5   config/secure/router.json5 reading DIR/users.txt, for a router
#                      outside Docker (`zenav router --zenoh-config DIR/router.json5`)
# A user that already has a password keeps it; delete DIR to renew them all.
set -eu

here=$(cd "$(dirname "$0")" && pwd)
dir="$here/secure/secrets"
if [ "${1:-}" = "-d" ]; then
    dir=$2
    shift 2
fi

umask 077
mkdir -p "$dir"
# The directory keeps other host users out; the files stay readable (0644) because
# compose mounts each one into a container whose user is not the host's.
chmod 700 "$dir"
dir=$(cd "$dir" && pwd)
printf '*\n' > "$dir/.gitignore"
touch "$dir/users.txt"

for user in sim odometry vps localizer navigator motor operator viewer "$@"; do
    case $user in
        *[!A-Za-z0-9_-]* | "") echo "make-secrets: bad user name '$user' (use A-Z a-z 0-9 _ -)" >&2; exit 2 ;;
    esac
    if grep -q "^$user:" "$dir/users.txt"; then
        continue
    fi
    password=$(od -An -N24 -tx1 /dev/urandom | tr -d ' \n')  # 192 random bits, hex
    printf '%s:%s\n' "$user" "$password" >> "$dir/users.txt"
    printf '{ transport: { auth: { usrpwd: { user: "%s", password: "%s" } } } }\n' "$user" "$password" > "$dir/$user.json5"
    chmod 644 "$dir/$user.json5"
    echo "make-secrets: new password for $user"
done
chmod 644 "$dir/users.txt"

sed "s|/run/secrets/zenoh_users|$dir/users.txt|" "$here/../config/secure/router.json5" > "$dir/router.json5"
chmod 644 "$dir/router.json5"
echo "make-secrets: secrets in $dir"
