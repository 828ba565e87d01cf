"""How well a checkpoint's auxiliary depth head sees the way ahead blocked (run 7, policy.depth_veto).

    python depth_head_check.py CHECKPOINT_DIR VAL_EXPERT_ROOT_WITH_DEPTH FIRST_COL END_COL

On every frame of an expert dataset written with rvn-gen dataset.save_depth=true: the clearance
(min depth over grid columns FIRST_COL:END_COL; 4 12 is depth_veto.py's central half of 16) from
the rendered depth and from the head, and per threshold the frames truly / predictedly below it
and the expert's forward steps it would veto.
"""
import sys, numpy as np, torch
from pathlib import Path
from rvn_il.policies import load_policy
from rvn_il.data.images import preprocess_image
from rvn_data.dataset.reader import read_rgb, read_meta
torch.set_num_threads(1)
pol = load_policy(sys.argv[1]); m = pol.members[0]
root = Path(sys.argv[2]); dirs = sorted(p for p in root.iterdir() if (p / 'depth.npy').is_file())
T, P, A = [], [], []
cols = slice(int(sys.argv[3]), int(sys.argv[4]))
with torch.no_grad():
    for d in dirs:
        depth = np.load(d / 'depth.npy').astype(np.float32); acts = read_meta(d)['actions']
        for t in range(len(depth)):
            img = preprocess_image(read_rgb(d / f'{t}.jpg'), m.model.image_size, m.crop)
            x = torch.from_numpy(img).permute(2, 0, 1)[None].float() / 255
            tok = m.model.encode_frames(x)
            pred = m.model.depth_head(tok).view(16, 16).exp().numpy()
            tr = depth[t].copy(); tr[tr == 0] = 50
            T.append(tr[:, cols].min()); P.append(pred[:, cols].min()); A.append(acts[t] if t < len(acts) else -1)
T, P, A = map(np.array, (T, P, A))
print('frames', len(T), 'abs log err median', np.median(np.abs(np.log(P / T))).round(3))
for thr in (0.4, 0.45, 0.5, 0.6):
    tb, pb = T < thr, P < thr
    print(f'thr {thr}: true blocked {tb.sum()}, pred blocked {pb.sum()}, both {(tb & pb).sum()}, false veto {(pb & ~tb).sum()}; expert fwd with true<thr {((A == 1) & tb).sum()}, expert fwd vetoed {((A == 1) & pb).sum()} of {(A == 1).sum()}')
