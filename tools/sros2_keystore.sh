#!/usr/bin/env bash
# Creates an SROS2 keystore and enclaves in it with the openssl command line alone: the layout
# `ros2 security create_keystore` and `ros2 security create_enclave` make (with a ROS 2
# installation those commands make the same files), which the ROS 2 bridge's DDS Security
# reads (`[ros2] security_enclave`, docs/ros2.md "Security").
#
# Usage: tools/sros2_keystore.sh KEYSTORE ENCLAVE [ENCLAVE...]
#   KEYSTORE  directory; created with its CA (one key for the identity and the permissions CA,
#             as SROS2 does) and the signed domain governance when it holds none yet
#   ENCLAVE   enclave name, e.g. /lwr/fri_ros2 (the bridge) or /lwr/operator (a client): each
#             gets KEYSTORE/enclaves/<name>/ with its identity certificate (CN=<name>), its
#             private key (mode 600) and permissions to publish and subscribe every topic of
#             domains 0-232, signed by the keystore's CA
#
# The governance: unauthenticated participants are refused, joining the domain and every topic's
# reads and writes are access-controlled, discovery and liveliness are encrypted, every submessage
# is signed (HMAC with the sender's key: a forged or replayed submessage is rejected). Unlike
# SROS2's default governance the data itself is not encrypted (data_protection_kind NONE) and
# RTPS messages are not protected as a whole: with RustDDS 0.15.1 (the bridge's DDS) encrypted
# data and signed RTPS messages failed to decode between two participants (ring "Unspecified"
# errors, no reply: ros2/tests/security.rs with those kinds). Whoever holds
# an enclave's key.pem may command the arm: keep the keystore's private/ directory off the robot
# PC, give each client its own enclave, and restrict its permissions (edit permissions.xml,
# re-sign with the smime line below) to the services it needs.
set -euo pipefail

if [ $# -lt 2 ]; then
    echo "usage: $0 KEYSTORE ENCLAVE [ENCLAVE...]" >&2
    exit 2
fi
keystore="$1"
shift
days=3650

umask 022
mkdir -p "$keystore/public" "$keystore/enclaves"
install -d -m 700 "$keystore/private"

if [ ! -f "$keystore/private/ca.key.pem" ]; then
    openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$keystore/private/ca.key.pem"
    chmod 600 "$keystore/private/ca.key.pem"
    cfg="$(mktemp)"
    printf '[req]\nprompt = no\ndistinguished_name = dn\n[dn]\nCN = sros2CA\n' >"$cfg"
    openssl req -new -x509 -config "$cfg" -key "$keystore/private/ca.key.pem" \
        -out "$keystore/public/ca.cert.pem" -days "$days" -sha256
    rm -f "$cfg"
    for role in identity_ca permissions_ca; do
        ln -sf ca.cert.pem "$keystore/public/$role.cert.pem"
        ln -sf ca.key.pem "$keystore/private/$role.key.pem"
    done
    cat >"$keystore/enclaves/governance.xml" <<'EOF'
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id_range><min>0</min><max>232</max></id_range>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>SIGN</metadata_protection_kind>
          <data_protection_kind>NONE</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
    openssl smime -sign -text -in "$keystore/enclaves/governance.xml" \
        -out "$keystore/enclaves/governance.p7s" \
        -signer "$keystore/public/permissions_ca.cert.pem" \
        -inkey "$keystore/private/permissions_ca.key.pem"
fi

for enclave in "$@"; do
    case "$enclave" in
    /*) ;;
    *) echo "enclave names start with / (e.g. /lwr/fri_ros2): $enclave" >&2; exit 2 ;;
    esac
    if ! [[ "$enclave" =~ ^(/[A-Za-z_][A-Za-z0-9_]*)+$ ]]; then
        echo "enclave name: /-separated segments of letters, digits and _: $enclave" >&2
        exit 2
    fi
    dir="$keystore/enclaves${enclave}"
    mkdir -p "$dir"
    chmod 755 "$dir"
    # The public files, as SROS2 links them.
    rel="$(realpath --relative-to="$dir" "$keystore")"
    ln -sf "$rel/public/identity_ca.cert.pem" "$dir/identity_ca.cert.pem"
    ln -sf "$rel/public/permissions_ca.cert.pem" "$dir/permissions_ca.cert.pem"
    ln -sf "$rel/enclaves/governance.p7s" "$dir/governance.p7s"
    (umask 077 && openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$dir/key.pem")
    chmod 600 "$dir/key.pem"
    cfg="$(mktemp)"
    printf '[req]\nprompt = no\ndistinguished_name = dn\n[dn]\nCN = %s\n' "$enclave" >"$cfg"
    csr="$(mktemp)"
    openssl req -new -config "$cfg" -key "$dir/key.pem" -out "$csr" -sha256
    openssl x509 -req -in "$csr" -CA "$keystore/public/identity_ca.cert.pem" \
        -CAkey "$keystore/private/identity_ca.key.pem" -set_serial "0x$(openssl rand -hex 8)" \
        -days "$days" -sha256 -out "$dir/cert.pem"
    rm -f "$cfg" "$csr"
    not_before="$(date -u +%Y-%m-%dT%H:%M:%S)"
    not_after="$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)"
    cat >"$dir/permissions.xml" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$enclave">
      <subject_name>CN=$enclave</subject_name>
      <validity>
        <not_before>$not_before</not_before>
        <not_after>$not_after</not_after>
      </validity>
      <allow_rule>
        <domains>
          <id_range><min>0</min><max>232</max></id_range>
        </domains>
        <publish><topics><topic>*</topic></topics></publish>
        <subscribe><topics><topic>*</topic></topics></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
    openssl smime -sign -text -in "$dir/permissions.xml" -out "$dir/permissions.p7s" \
        -signer "$keystore/public/permissions_ca.cert.pem" \
        -inkey "$keystore/private/permissions_ca.key.pem"
    echo "$dir"
done
