# A pg_auto_failover node (monitor or data node) from Debian 12's packages, for
# docker/compose-ha.yaml: the same packages scripts/pg_cluster.sh runs on one machine.
#
#   docker compose -f docker/compose-ha.yaml up -d --build
FROM debian:bookworm-slim
RUN apt-get update \
 && apt-get install -y --no-install-recommends postgresql-15 postgresql-15-auto-failover \
      pg-auto-failover-cli \
 && rm -rf /var/lib/apt/lists/* \
 && mkdir -p /var/lib/pgaf && chown postgres /var/lib/pgaf
ENV PATH=/usr/lib/postgresql/15/bin:$PATH PGDATA=/var/lib/pgaf/data \
    XDG_CONFIG_HOME=/var/lib/pgaf/config XDG_DATA_HOME=/var/lib/pgaf/share
USER postgres
VOLUME /var/lib/pgaf
