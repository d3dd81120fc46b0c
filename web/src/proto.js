// The skimap.v1 messages the viewer reads in the protobuf binary encoding (REST with
// `Accept: application/x-protobuf`, docs/api.md): the voxel and label pages, whose JSON
// costs the server 15-60x what the page does. The types come from the repository's own
// .proto files (bundled as text by vite), so they cannot drift from the server's.
import protobuf from 'protobufjs';
import geometry from '../../proto/skimap/v1/geometry.proto?raw';
import queries from '../../proto/skimap/v1/queries.proto?raw';
import instances from '../../proto/skimap/v1/instances.proto?raw';

let root = null;

// The message type `name` (e.g. 'skimap.v1.GetVoxelsResponse'); field names in
// lowerCamelCase, as in the JSON mapping.
export function messageType(name) {
  if (!root) {
    root = new protobuf.Root();
    // instances.proto imports google/protobuf/timestamp.proto: protobufjs ships it.
    root.addJSON(protobuf.common.get('google/protobuf/timestamp.proto').nested);
    for (const source of [geometry, queries, instances]) protobuf.parse(source, root);
    root.resolveAll();
  }
  return root.lookupType(name);
}

// Decodes `bytes` (an ArrayBuffer) as message type `name`; missing fields read as their
// defaults (0, '', null for a message).
export function decode(name, bytes) {
  return messageType(name).decode(new Uint8Array(bytes));
}
