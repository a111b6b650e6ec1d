// pinyin-pro's reading of an evaluation set, for eval_tones to score beside Facecast's:
//   node tests/viseme/eval/pinyin_pro.mjs tests/viseme/eval/zh_tones.tsv > build/zh_tones.pinyin-pro.tsv
// Output: text <TAB> numbered pinyin of every Han character (5 = neutral tone), lexical tones
// (toneSandhi off: the reference has no 一/不 sandhi either). pinyin-pro is a devDependency;
// $PINYIN_PRO_DIR may name another folder whose node_modules holds it.
import { readFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

const base = process.env.PINYIN_PRO_DIR
  ? path.join(process.env.PINYIN_PRO_DIR, 'package.json')
  : import.meta.url;
const { pinyin } = createRequire(base)('pinyin-pro');

const file = process.argv[2];
if (!file) {
  console.error('usage: node pinyin_pro.mjs SET.tsv');
  process.exit(2);
}
for (const line of readFileSync(file, 'utf8').split('\n')) {
  if (!line || line.startsWith('#')) continue;
  const text = line.split('\t')[1];
  const han = [...text].filter((c) => /\p{Script=Han}/u.test(c)).join('');
  const syllables = pinyin(han, { toneType: 'num', type: 'array', toneSandhi: false })
    .map((s) => s.replace(/0$/, '5').replace('ü', 'v'));
  console.log(`${text}\t${syllables.join(' ')}`);
}
