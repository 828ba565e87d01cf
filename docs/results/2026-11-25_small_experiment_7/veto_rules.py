"""Two forward-veto rules, with a checkpoint's predicted depth and with the rendered depth (run 7).

    python veto_rules.py CHECKPOINT_DIR NEGATIVE_ROOT EXPERT_ROOT   # both written with dataset.save_depth=true

band: policy.depth_veto's rule (min depth in the central half of the 16 columns below zmax);
swept: any grid cell inside the rectangle a forward step sweeps (|x| <= r_robot + margin, z <= zmax,
margin = zmax - d_step - r_robot; 90 deg hfov). Counted: the negatives' collision frames t_c that
each rule flags (recall) and the expert's forward steps it would veto.
"""
import sys, json, numpy as np, torch
from pathlib import Path
from rvn_il.policies import load_policy
from rvn_il.data.images import preprocess_image
from rvn_data.dataset.reader import read_rgb, read_meta
torch.set_num_threads(1)
pol = load_policy(sys.argv[1]); m = pol.members[0]
S = 16; tan = ((np.arange(S) + 0.5) / S * 2 - 1)  # 90 deg hfov
def pred_depth(d, t):
    img = preprocess_image(read_rgb(d / f'{t}.jpg'), m.model.image_size, m.crop)
    return m.model.depth_head(m.model.encode_frames(torch.from_numpy(img).permute(2, 0, 1)[None].float() / 255)).view(S, S).exp().numpy()
def swept(z, zmax, r=0.18, d=0.25):
    margin = max(0.0, zmax - d - r)
    return bool(((np.abs(z * tan[None]) <= r + margin) & (z <= zmax)).any())
def band(z, zmax):
    return z[:, 4:12].min() < zmax
neg, exp = [], []
with torch.no_grad():
    for d in sorted(p for p in Path(sys.argv[2]).iterdir() if (p / 'depth.npy').is_file()):
        t = json.loads((d / 'rvn_meta.json').read_text())['t_c']
        z = np.load(d / 'depth.npy').astype(np.float32)[t]; z[z == 0] = 50
        neg.append((z, pred_depth(d, t)))
    for d in sorted(p for p in Path(sys.argv[3]).iterdir() if (p / 'depth.npy').is_file()):
        acts = read_meta(d)['actions']; Z = np.load(d / 'depth.npy').astype(np.float32)
        for t in range(min(len(acts), len(Z))):
            if acts[t] == 1:
                z = Z[t].copy(); z[z == 0] = 50
                exp.append((z, pred_depth(d, t)))
print('negatives', len(neg), 'expert forward steps', len(exp))
for zmax in (0.45, 0.5, 0.55, 0.6):
    for name, f in (('band', band), ('swept', lambda z, q: swept(z, q))):
        print(f'{name:6} zmax {zmax}: collisions caught true {sum(f(a, zmax) for a, _ in neg)} pred {sum(f(b, zmax) for _, b in neg)}'
              f' | expert fwd vetoed true {sum(f(a, zmax) for a, _ in exp)} pred {sum(f(b, zmax) for _, b in exp)}')
