#!/usr/bin/env python3
"""The layers, checked: what each part of the tree may include (docs/architecture.md,
"Layers").

  check_layers.py SOURCE_DIR                 scan every production #include against LAYERS
  check_layers.py SOURCE_DIR --build DIR     also: the include roots each library compiles
                                             with (DIR/compile_commands.json) give it exactly
                                             the layers LAYERS allows, and a wrong-way include
                                             fails to compile while a right-way one compiles
  check_layers.py --self-test                the scan finds a wrong-way include planted in a
                                             scratch tree (so this check can fail)

The scan also holds production files to MAX_LINES lines (the house rule: a file over it is
split by concern).

Exit 0 when everything holds; 1 with one line per violation otherwise.
"""
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile

# Each layer: its folders (a file belongs to the longest matching prefix), its CMake targets,
# and the layers it may include directly (it sees their dependencies too: the closure).
LAYERS = {
    'base':        (['base/'], ['skimap_base'], []),
    'codec':       (['codec/'], ['skimap_codec', 'skimap_image_codec'], []),
    'skimap':      (['skimap/'], ['skimap'], ['base']),
    'dataset':     (['dataset/'], ['skimap_dataset'], ['codec']),
    'sim':         (['sim/'], ['skimap_sim', 'skimap-sim', 'skimap-model-views'], ['dataset']),
    'proto':       (['skimap/v1/'], ['skimap_proto'], []),
    'perception':  (['perception/'], ['skimap_perception'], ['skimap', 'codec', 'base']),
    'objects':     (['perception/objects/'], ['skimap_objects'], ['skimap', 'dataset', 'base']),
    'recognition': (['perception/recognition/'], ['skimap_recognition'],
                    ['perception', 'objects']),
    'storage':     (['storage/'], ['skimap_storage'], ['base']),
    'core':        (['server/core/'], ['skimap_server_core'],
                    ['perception', 'objects', 'recognition', 'storage', 'proto', 'skimap',
                     'codec', 'base']),
    'grpc':        (['server/grpc/'], ['skimap_grpc'], ['core', 'proto']),
    'http':        (['server/http/'], ['skimap_http'], ['core', 'proto']),
    'app':         (['server/app/'], ['skimap_server', 'skimapd'], ['grpc', 'http', 'core']),
    'client':      (['client/'], ['skimap_client'], ['proto', 'codec', 'base']),
    'bag':         (['ros/bag/'], ['skimap_bag'], ['proto', 'codec', 'base']),
    'cli':         (['client/cli/'], ['skimap_cli'], ['client', 'dataset', 'bag', 'sim']),
    'rosbridge':   (['ros/bridge/'], ['skimap_ros_bridge', 'skimap-ros'], ['client', 'bag']),
    'tools':       (['tools/'], ['skimap-load'], ['proto']),
}
# Headers a layer must not include at all, whatever it links: the cores are transport
# independent (the adapters are server/grpc and server/http).
FORBIDDEN_SYSTEM = {
    'core': [r'^grpcpp/', r'^grpc/', r'\.grpc\.pb\.h$', r'^httplib\.h$'],
    'storage': [r'^grpcpp/', r'\.pb\.h$', r'^opencv2/'],
    'skimap': [r'^grpcpp/', r'\.pb\.h$', r'^opencv2/', r'^sqlite3\.h$'],
    'base': [r'^grpcpp/', r'\.pb\.h$', r'^opencv2/'],
    'perception': [r'^grpcpp/', r'\.pb\.h$', r'^sqlite3\.h$', r'^libpq-fe\.h$'],
    'objects': [r'^grpcpp/', r'\.pb\.h$', r'^sqlite3\.h$', r'^libpq-fe\.h$'],
    'recognition': [r'^grpcpp/', r'\.pb\.h$', r'^sqlite3\.h$', r'^libpq-fe\.h$'],
}
MAX_LINES = 420
PRODUCTION = ['base', 'codec', 'skimap', 'dataset', 'sim', 'perception', 'storage', 'server',
              'ros', 'client', 'tools']
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^">]+)[">]', re.M)


def closure(layer):
    seen, todo = set(), list(LAYERS[layer][2])
    while todo:
        d = todo.pop()
        if d not in seen:
            seen.add(d)
            todo.extend(LAYERS[d][2])
    return seen


def layer_of(path):
    best, best_len = None, -1
    for name, (prefixes, _, _) in LAYERS.items():
        for p in prefixes:
            if path.startswith(p) and len(p) > best_len:
                best, best_len = name, len(p)
    return best


def scan(root):
    """Every quoted include of every production file, against LAYERS."""
    errors, files = [], 0
    for top in PRODUCTION:
        for dirpath, _, names in os.walk(os.path.join(root, top)):
            for n in names:
                if not n.endswith(('.h', '.cc')):
                    continue
                path = os.path.relpath(os.path.join(dirpath, n), root)
                src = layer_of(path)
                if src is None:
                    errors.append(f'{path}: in no layer (add its folder to LAYERS)')
                    continue
                files += 1
                allowed = closure(src) | {src}
                text = open(os.path.join(root, path), errors='replace').read()
                if text.count('\n') > MAX_LINES:
                    errors.append(f'{path}: {text.count(chr(10))} lines, over {MAX_LINES}: '
                                  'split it by concern')
                for m in INCLUDE.finditer(text):
                    kind, inc = m.groups()
                    line = text.count('\n', 0, m.start()) + 1
                    for pat in FORBIDDEN_SYSTEM.get(src, []):
                        if re.search(pat, inc):
                            errors.append(f'{path}:{line}: layer {src} must not include {inc}')
                    if kind != '"' or '/' not in inc:
                        continue
                    if '..' in inc.split('/'):
                        errors.append(f'{path}:{line}: relative include {inc}')
                        continue
                    dst = layer_of(inc)
                    if dst is None:
                        continue  # a library's header (Eigen/..., absl/..., nlohmann/...)
                    if dst not in allowed:
                        errors.append(f'{path}:{line}: layer {src} includes {inc} of layer '
                                      f'{dst}; {src} may include {sorted(allowed)}')
    return errors, files


def compile_commands(build):
    """target -> one compile command (as an argument list) of a source of that target."""
    by_target = {}
    for entry in json.load(open(os.path.join(build, 'compile_commands.json'))):
        args = entry.get('arguments') or shlex.split(entry['command'])
        m = re.search(r'CMakeFiles/([^/]+)\.dir/', entry.get('output', '') or ' '.join(args))
        if m and m.group(1) not in by_target:
            by_target[m.group(1)] = (entry['directory'], args)
    return by_target


def check_build(root, build):
    errors = []
    cmds = compile_commands(build)
    target_layer = {t: name for name, (_, targets, _) in LAYERS.items() for t in targets}
    inc_root = os.path.join(os.path.realpath(build), 'include')
    checked = 0
    for target, (directory, args) in sorted(cmds.items()):
        layer = target_layer.get(target)
        if layer is None or layer == 'proto':
            continue  # tests, benchmarks, fuzzers see the whole tree; protos are generated
        checked += 1
        seen = set()
        for i, a in enumerate(args):
            d = a[2:] if a.startswith('-I') else (args[i + 1] if a in ('-I', '-isystem') else None)
            if d is None:
                continue
            d = os.path.realpath(os.path.join(directory, d))
            if d == os.path.realpath(root):
                errors.append(f'{target}: the repository root is an include directory')
            if d.startswith(inc_root + os.sep):
                t = os.path.relpath(d, inc_root).split(os.sep)[0]
                if t in target_layer:
                    seen.add(target_layer[t])
        want = closure(layer) | {layer}
        want.discard('proto')  # the generated headers' root is proto's build folder
        seen.discard('proto')
        if seen != want:
            errors.append(f'{target} (layer {layer}) sees layers {sorted(seen)}, '
                          f'LAYERS allows {sorted(want)}')
        errors += probe(root, target, layer, directory, args)
    if checked < 15:
        errors.append(f'only {checked} libraries found in {build}/compile_commands.json')
    return errors


def sample_header(root, layer):
    """The smallest header of `layer`, as an include path."""
    best = None
    for prefix in LAYERS[layer][0]:
        d = os.path.join(root, prefix)
        if not os.path.isdir(d):
            continue
        for n in os.listdir(d):
            p = prefix + n
            if n.endswith('.h') and layer_of(p) == layer:
                size = os.path.getsize(os.path.join(root, p))
                if best is None or size < best[0]:
                    best = (size, p)
    return best[1] if best else None


def probe(root, target, layer, directory, args):
    """Preprocesses one include of an allowed and one of a forbidden layer with `target`'s
    flags: the first must be found, the second not."""
    errors = []
    allowed = closure(layer) - {'proto'}
    forbidden = [l for l in LAYERS if l not in allowed and l not in (layer, 'proto')]
    cases = []
    if allowed:
        cases.append((sample_header(root, sorted(allowed)[0]), True))
    for f in ('app', 'core', 'storage', 'client'):
        if f in forbidden:
            cases.append((sample_header(root, f), False))
            break
    flags = []
    skip = False
    for i, a in enumerate(args[1:], 1):
        if skip:
            skip = False
            continue
        if a in ('-o', '-c', '-MF', '-MT', '-MQ'):
            skip = True
            continue
        if a.startswith(('-o', '-MD', '-MMD', '-MF', '-MT', '-MQ')) or not a.startswith('-') \
                and (a.endswith(('.cc', '.cxx', '.cpp'))):
            continue
        flags.append(a)
    compiler = args[0]
    if os.path.basename(compiler) == 'ccache':
        compiler, flags = flags[0], flags[1:]
    for header, ok in cases:
        if header is None:
            continue
        with tempfile.NamedTemporaryFile('w', suffix='.cc', delete=False) as f:
            f.write(f'#include "{header}"\n')
        try:
            # The preprocessor alone: whether a header is visible is all the include roots
            # decide (a tenth of the time of -fsyntax-only over the 20-odd libraries).
            r = subprocess.run([compiler, *flags, '-E', '-o', os.devnull, f.name],
                               cwd=directory, capture_output=True, text=True)
        finally:
            os.unlink(f.name)
        # A forbidden include must fail for the right reason: the header is not found.
        refused = r.returncode != 0 and ('No such file' in r.stderr or 'not found' in r.stderr)
        if not (r.returncode == 0 if ok else refused):
            what = 'preprocesses' if r.returncode == 0 else 'fails: ' + r.stderr[:300]
            errors.append(f'{target}: #include "{header}" {what} (expected '
                          f'{"to be found" if ok else "not to be found"})')
    return errors


def self_test():
    with tempfile.TemporaryDirectory() as root:
        for d, body in [('base/a.h', '#include "absl/status/status.h"\n'),
                        ('skimap/b.h', '#include "base/a.h"\n'),
                        ('storage/c.cc', '#include "server/core/maps/d.h"\n'),
                        ('server/core/maps/d.h', '#include <grpcpp/grpcpp.h>\n'),
                        ('server/core/maps/e.cc', '//\n' * (MAX_LINES + 1))]:
            os.makedirs(os.path.join(root, os.path.dirname(d)), exist_ok=True)
            open(os.path.join(root, d), 'w').write(body)
        errors, _ = scan(root)
        want = ['storage/c.cc:1: layer storage includes server/core/maps/d.h',
                'server/core/maps/d.h:1: layer core must not include grpcpp/grpcpp.h',
                f'server/core/maps/e.cc: {MAX_LINES + 1} lines, over {MAX_LINES}']
        missing = [w for w in want if not any(e.startswith(w) for e in errors)]
        if missing or len(errors) != len(want):
            print('self-test: expected exactly', want, 'got', errors)
            return 1
    print('self-test: the scan finds the three planted violations and nothing else')
    return 0


def main(argv):
    if argv[1:] == ['--self-test']:
        return self_test()
    root = os.path.realpath(argv[1])
    errors, files = scan(root)
    if '--build' in argv:
        errors += check_build(root, argv[argv.index('--build') + 1])
    for e in errors:
        print(e)
    if errors:
        print(f'layers: {len(errors)} violation(s)')
        return 1
    print(f'layers: {files} files include only what their layer may'
          + (', and every library compiles with exactly its layers' if '--build' in argv
             else ''))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
